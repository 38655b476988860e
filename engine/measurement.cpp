#include "engine/measurement.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/correlation.h"
#include "models/linear/fir_estimator.h"

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

LoopConsistency check_loop(const Eigen::VectorXd& played, const Eigen::VectorXd& heard, int round_trip, double tolerance) {
  const Eigen::Index n = played.size();
  if (heard.size() != n) throw std::invalid_argument("loop check: the played and heard signals differ in length");
  if (round_trip < 0 || round_trip >= n) {
    throw std::invalid_argument("loop check: round trip " + std::to_string(round_trip) + " outside the record of " +
                                std::to_string(n) + " samples");
  }
  // The FIR starts a few samples before the correlation's peak: the converters' filters answer before it.
  const Eigen::Index lead = std::min<Eigen::Index>(8, round_trip), shift = round_trip - lead, m = n - shift;
  if (m < 4 * kLoopTaps) throw std::invalid_argument("loop check: the record is too short for the loop's FIR");
  const Eigen::VectorXd x = played.head(m), z = heard.segment(shift, m);
  // y(k) = Σ_j b_j·x(k−j), least squares over the whole record; a ridge keeps bands the drive leaves
  // unexcited at no response.
  const Eigen::VectorXd b = models::estimate_fir(x, z, kLoopTaps, 1e-9);
  const Eigen::VectorXd residual = z - models::simulate_fir(b, x);
  double loudest = 0.0;
  for (Eigen::Index k = kLoopTaps; k + kLoopWindow <= m; k += kLoopWindow) {
    loudest = std::max(loudest, z.segment(k, kLoopWindow).squaredNorm());
  }
  LoopConsistency out;
  for (Eigen::Index k = kLoopTaps; k + kLoopWindow <= m; k += kLoopWindow) {
    const double energy = z.segment(k, kLoopWindow).squaredNorm();
    if (!(energy > 1e-3 * loudest)) continue;
    const double r = residual.segment(k, kLoopWindow).squaredNorm() / energy;
    if (r > out.worst_residual) {
      out.worst_residual = r;
      out.worst_at = k + shift;
    }
  }
  out.slipped = !(out.worst_residual <= tolerance);
  return out;
}

}  // namespace panelbass::engine
