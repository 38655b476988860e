#pragma once
// The figures of the Analysis report, drawn by gnuplot from a models::ModelAnalysis.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/gnuplot.h"
#include "models/analysis/model_analysis.h"

namespace panelbass::cli {

/// One image of the report.
struct ReportFigure {
  std::string name;               ///< file stem and JSON key: "time", "psd", "frf", …
  std::string caption;            ///< one sentence for the HTML report
  std::filesystem::path path;     ///< the image written
};

/// How the figures are drawn.
struct ReportPlotOptions {
  PlotFormat format = PlotFormat::png;
  Eigen::Index window = 600;      ///< samples of the time plot (from the first judged sample)
};

/// Draws every figure the analysis has data for into `dir` (which must exist): time, psd, frf, residual
/// tests, and when present poles/zeros with the root locus, J per iteration and harmonics (one per drive
/// amplitude). Throws std::runtime_error if gnuplot is missing or fails.
std::vector<ReportFigure> plot_analysis(const models::ModelAnalysis& a, const std::filesystem::path& dir,
                                        const ReportPlotOptions& options);

}  // namespace panelbass::cli
