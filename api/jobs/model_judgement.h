#pragma once
// How a job judges a model on a record: J by simulation with measured outputs setting the state, the fit
// and spectrum plots, and the harmonic distortion of plant and model side by side when the plant is known.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "api/jobs/excitation_record.h"
#include "api/jobs/job_environment.h"
#include "api/jobs/job_progress.h"
#include "models/analysis/distortion_comparison.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {

/// Measured outputs that set a simulation's state before J is computed (the CLI's --init default).
inline constexpr Eigen::Index kInit = 50;

/// The state-setting samples for a record part of `samples`: min(kInit, samples/10).
Eigen::Index init_samples(Eigen::Index samples);

/// [2A] simulation J (percent) of `model` on u → y with init_samples() measured outputs setting its state;
/// NaN for an empty record.
double simulation_j(const models::AnyModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y);

/// {"fit", "spectrum"} plots of `model` on the judged part of `r`.
nlohmann::json model_plots(const models::AnyModel& model, const ExcitationRecord& r, double fs);

/// The result of a job that identified a model through a use case: {"model_id", "j_est_pct" and "j_val_pct" (its
/// summary's J_est_pct and J_val_pct), "summary", "warnings", "plots":{"fit","spectrum"}} of the model's free run
/// `y_sim` on the judged part `part` of its record.
nlohmann::json identified_model_result(const std::string& model_id, const nlohmann::json& summary,
                                       const std::vector<std::string>& warnings, const JudgedPart& part,
                                       const Eigen::VectorXd& y_sim, double fs);

/// The same result with its plots given.
nlohmann::json identified_model_result(const std::string& model_id, const nlohmann::json& summary,
                                       const std::vector<std::string>& warnings, nlohmann::json plots);

/// The stepped-sine harmonic distortion measurement (H2/H3 at the record's drive level) that compares the
/// server's plant with a model at `model_fs`; nullopt unless the plant is known and runs at that rate.
std::optional<models::DistortionSpec> harmonic_spec(const JobEnvironment& env, double model_fs,
                                                    const ExcitationRecord& r);

/// The "harmonics" plot of the plant's and `model`'s H2/H3 (harmonic_spec()); null when there is no spec.
nlohmann::json harmonics_if_known(const JobEnvironment& env, const models::AnyModel& model, const ExcitationRecord& r,
                                  JobProgress& progress);

}  // namespace panelbass::api
