#pragma once
// The flattest LQ feedforward design a program amplitude allows: the input weight R of [7A] searched so
// that the controller's safe amplitude for band-limited white noise (models::max_input) meets a target.
// The thesis fixes R and lowers the program until u* stays within [−1, 1] (the table after fig. 7.8);
// a product fixes the program's level and wants the flattest response that still fits.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "dsp/biquad.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"

namespace panelbass::models {

/// The search's range of R: cheaper control than kMinSearchR is not tried, and at kMaxSearchR the
/// feedback is as good as off.
inline constexpr double kMinSearchR = 1e-8;
inline constexpr double kMaxSearchR = 1e6;

/// The design found by design_lq_for_input().
struct LqWeightSearch {
  LqFeedforward ff;       ///< the controller at the R found (ff.weights.R)
  double target_noise_amplitude = 0.0;  ///< the safe amplitude asked for
  InputLimits limits;     ///< its safe amplitudes; limits.noise ≥ the target
  int designs = 0;        ///< LQ designs tried
  bool at_lower_bound = false;  ///< the target is met already at kMinSearchR (R not pushed lower)
};

/// The smallest R in [kMinSearchR, kMaxSearchR] (to 1 %) whose design on `model` with output weight `R0`
/// keeps u* within [−1, 1] for uniform white noise of peak `target_noise_amplitude` behind `band_pass`
/// (max_input(…, samples, seed).noise ≥ target), by bisection on log R: more weight on u* shrinks the
/// controller's gain, so the safe amplitude grows with R. Throws std::invalid_argument for a target
/// outside (0, 1], or one that even kMaxSearchR does not reach (naming the amplitude it allows).
LqWeightSearch design_lq_for_input(const LinearModel& model, double R0, double target_noise_amplitude,
                                   const std::vector<dsp::Biquad>& band_pass, Eigen::Index samples = 100000,
                                   std::uint64_t seed = 1);

/// The search as the controller's meta and the design's result carry it ("R_search"):
/// {"target_noise_amplitude", "designs", "at_lower_bound"}.
nlohmann::json lq_weight_search_report(const LqWeightSearch& search);

}  // namespace panelbass::models
