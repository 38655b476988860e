#pragma once
// Plot-ready columns of a job's result (ROUTES.md "Jobs"): every plot is an object of equal-length
// columns, and every number in a result is finite or null (JSON has no NaN or infinity).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <vector>

#include "models/analysis/distortion_comparison.h"

namespace panelbass::api {


/// A copy of `value` with every non-finite number replaced by null.
nlohmann::json without_non_finite(const nlohmann::json& value);

/// The samples of `x` as a column (non-finite entries null).
nlohmann::json column(const Eigen::VectorXd& x);

/// "fit": {"t":[s],"measured","simulated"} of the first ≤ `max_points` samples; sample k is at
/// (first_sample + k)/fs seconds. Throws std::invalid_argument for unequal lengths.
nlohmann::json fit_plot(const Eigen::VectorXd& measured, const Eigen::VectorXd& simulated, double fs,
                        Eigen::Index first_sample = 0, Eigen::Index max_points = 2000);

/// "spectrum": {"f":[Hz],"measured_db","model_db"}: magnitudes of the H1 estimates u → y and u → y_model
/// (Welch, dsp::welch_segment()), the bins above DC. Throws std::invalid_argument for unequal lengths or a
/// record shorter than 64 samples.
nlohmann::json spectrum_plot(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& y_model, double fs);

/// "spectrum" of two responses on the frequencies `f` (Hz), the bins above DC (f > 0) only.
nlohmann::json spectrum_plot(const Eigen::VectorXd& f, const Eigen::VectorXcd& measured, const Eigen::VectorXcd& model);

/// "residual_spectrum": {"frequency_hz","before_db","after_db","noise_floor_db"}: Welch PSDs (the diagnosis's residual segment,
/// dB re 1 unit²/Hz) of two residuals of one record, the bins above DC, with the constant `noise_psd`
/// (units²/Hz; null where not positive) beside them. Throws std::invalid_argument for unequal lengths or
/// fewer than 64 samples.
nlohmann::json residual_spectrum_plot(const Eigen::VectorXd& residual_before, const Eigen::VectorXd& residual_after,
                                      double noise_psd, double fs);

/// One point of a J history.
struct HistoryPoint {
  int iteration = 0;
  double j_est_pct = 0.0;
  double j_val_pct = 0.0;  ///< NaN when there is no validation figure
};

/// "history": {"iteration","j_est_pct","j_val_pct"}.
nlohmann::json history_plot(const std::vector<HistoryPoint>& points);

/// "harmonics": {"f","measured_h2_db","measured_h3_db","model_h2_db","model_h3_db"} from the plant's and
/// the model's rows (the same order: frequency within amplitude), dB relative to the fundamental.
nlohmann::json harmonics_plot(const models::DistortionComparison& comparison);


}  // namespace panelbass::api
