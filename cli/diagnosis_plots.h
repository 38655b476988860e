#pragma once
// The figures of the diagnosis report, drawn by gnuplot from a models::Diagnosis and the validation
// record it judged its models on: the residual spectrum before and after, the fit, each gray-box term
// against the state it acts on, and validation J per step.

#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "cli/gnuplot.h"
#include "cli/report_plots.h"
#include "models/diagnosis/diagnosis.h"

namespace panelbass::cli {

/// The validation record a diagnosis was judged on, as it was given to models::diagnose.
struct DiagnosisValidation {
  const Eigen::VectorXd& u;  ///< drive, raw units
  const Eigen::VectorXd& y;  ///< measured response, raw units
  Eigen::Index init = 50;    ///< measured outputs that set a simulation's state (DiagnosisOptions::init)
};

/// How the diagnosis figures are drawn.
struct DiagnosisPlotOptions {
  PlotFormat format = PlotFormat::png;
  Eigen::Index window = 300;           ///< samples of the fit plot (from the first judged sample)
  Eigen::Index scatter_points = 3000;  ///< points at most in a term's scatter (the record thinned evenly)
};

/// Draws into `dir` (which must exist): "residual_spectrum", "fit", "j_per_step", "residual_vs_state", and "term-N" for every
/// gray-box term N (from 1) of the final model whose static feature varies with a state (a constant
/// offset, or a term without a static feature, is left out). Throws std::runtime_error if gnuplot is
/// missing or fails, std::invalid_argument if the record is shorter than `init` + 256 samples.
std::vector<ReportFigure> plot_diagnosis(const models::Diagnosis& diagnosis, const DiagnosisValidation& validation,
                                         const std::filesystem::path& dir, const DiagnosisPlotOptions& options);

}  // namespace panelbass::cli
