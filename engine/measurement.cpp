#include "engine/measurement.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/correlation.h"

namespace panelbass::engine {

Measurement::Measurement(std::vector<double> drive, std::size_t fade_samples) : drive_(std::move(drive)), fade_(fade_samples) {
  if (drive_.empty()) throw std::invalid_argument("measurement: the drive is empty");
  if (fade_ < 1) throw std::invalid_argument("measurement: the program's fade must be at least one sample");
  for (std::size_t k = 0; k < drive_.size(); ++k) {
    if (!std::isfinite(drive_[k]) || std::abs(drive_[k]) > 1.0) {
      throw std::invalid_argument("measurement: drive sample " + std::to_string(k) + " is " + std::to_string(drive_[k]) +
                                  ", outside [-1, 1]");
    }
  }
  for (auto& c : captured_) c.assign(drive_.size(), 0.0);
}

bool Measurement::begin() noexcept {
  if (cancelled()) {
    abort();
    return false;
  }
  state_.store(State::running, std::memory_order_release);
  return true;
}

double Measurement::step(double sensor, double current, double loopback, bool& done) noexcept {
  // Sample k's capture answers drive sample k: both pass the same period of the same model block.
  captured_[0][position_] = sensor;
  captured_[1][position_] = current;
  captured_[2][position_] = loopback;
  const double x = drive_[position_];
  done = ++position_ == drive_.size();
  if (done) state_.store(State::finished, std::memory_order_release);
  return x;
}

RoundTrip find_round_trip(const Eigen::VectorXd& played, const Eigen::VectorXd& heard, Eigen::Index max_lag) {
  const Eigen::VectorXd r = dsp::cross_correlation(played, heard, max_lag);
  Eigen::Index best = 0;
  r.maxCoeff(&best);
  RoundTrip trip;
  trip.samples = static_cast<int>(best);
  trip.peak = r[best];
  trip.fractional = static_cast<double>(best);
  if (best > 0 && best < r.size() - 1) {
    // The parabola through the peak and its neighbours: its vertex.
    const double a = r[best - 1], b = r[best], c = r[best + 1];
    const double curvature = a - 2.0 * b + c;
    if (curvature < 0.0) trip.fractional += 0.5 * (a - c) / curvature;
  }
  return trip;
}

}  // namespace panelbass::engine
