#include "models/control/lq_weight_search.h"
#include "models/io/number_text.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::models {
namespace {

// The bisection stops when the bracket [R_lo, R_hi] is this narrow (R_hi / R_lo).
constexpr double kRatioTolerance = 1.01;

std::string show(double v) { return number_text(v, 4); }

}  // namespace

LqWeightSearch design_lq_for_input(const LinearModel& model, double R0, double target_noise_amplitude,
                                   const std::vector<dsp::Biquad>& band_pass, Eigen::Index samples,
                                   std::uint64_t seed) {
  if (!(target_noise_amplitude > 0.0 && target_noise_amplitude <= 1.0)) {
    throw std::invalid_argument("the target input amplitude must be in (0, 1], got " + show(target_noise_amplitude));
  }
  LqWeightSearch search;
  search.target_noise_amplitude = target_noise_amplitude;
  const auto try_weight = [&](double R) {
    ++search.designs;
    LqFeedforward ff = design_lq(model, {R, R0});
    const InputLimits limits = max_input(ff, band_pass, samples, seed);
    return std::pair{std::move(ff), limits};
  };
  const auto meets = [&](const InputLimits& limits) { return limits.noise >= target_noise_amplitude; };

  auto [ff_hi, limits_hi] = try_weight(kMaxSearchR);
  if (!meets(limits_hi)) {
    throw std::invalid_argument("no R reaches the target input amplitude " + show(target_noise_amplitude) +
                                ": even R = " + show(kMaxSearchR) + " (feedback as good as off) allows " +
                                show(limits_hi.noise) + " behind this band-pass");
  }
  double r_lo = kMinSearchR, r_hi = kMaxSearchR;
  {
    auto [ff_lo, limits_lo] = try_weight(r_lo);
    if (meets(limits_lo)) {
      search.ff = std::move(ff_lo);
      search.limits = limits_lo;
      search.at_lower_bound = true;
      return search;
    }
  }
  // Invariant: R_lo allows less than the target, R_hi at least the target.
  while (r_hi / r_lo > kRatioTolerance) {
    const double r_mid = std::sqrt(r_lo * r_hi);
    auto [ff, limits] = try_weight(r_mid);
    if (meets(limits)) {
      r_hi = r_mid;
      ff_hi = std::move(ff);
      limits_hi = limits;
    } else {
      r_lo = r_mid;
    }
  }
  search.ff = std::move(ff_hi);
  search.limits = limits_hi;
  return search;
}

nlohmann::json lq_weight_search_report(const LqWeightSearch& search) {
  return {{"target_noise_amplitude", search.target_noise_amplitude},
          {"designs", search.designs},
          {"at_lower_bound", search.at_lower_bound}};
}

}  // namespace panelbass::models
