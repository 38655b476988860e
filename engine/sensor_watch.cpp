#include "engine/sensor_watch.h"

#include <cmath>

namespace panelbass::engine {

bool SensorWatch::update(double measured, double predicted) noexcept {
  const bool silent = std::abs(measured) <= options_.silence;  // NaN is not silent: the chain handles it
  if (!lost_) {
    if (!silent) {
      run_ = 0;
      predicted_energy_ = 0.0;
      return false;
    }
    ++run_;
    predicted_energy_ += predicted * predicted;
    if (run_ < options_.timeout) return false;
    const double loud = 10.0 * options_.silence;
    if (predicted_energy_ / run_ > loud * loud) {
      lost_ = true;
      run_ = 0;
      predicted_energy_ = 0.0;
      return true;
    }
    // Silence the model agrees with (the program is quiet): keep watching the latest `timeout` samples.
    run_ = 0;
    predicted_energy_ = 0.0;
    return false;
  }
  run_ = silent ? 0 : run_ + 1;
  if (run_ < options_.timeout) return false;
  lost_ = false;
  run_ = 0;
  return true;
}

void SensorWatch::reset() noexcept {
  lost_ = false;
  run_ = 0;
  predicted_energy_ = 0.0;
}

}  // namespace panelbass::engine
