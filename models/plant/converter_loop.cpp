#include "models/plant/converter_loop.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "dsp/butterworth.h"

namespace panelbass::models {
namespace {

// The continuous-time cascade of `filters` in state-space form (the sections' states in order, each fed by
// the previous section's output): ω/(s+ω) as x' = ω(in − x); ω²/(s² + (ω/q)s + ω²) as x1' = x2,
// x2' = ω²(in − x1) − (ω/q)·x2; the output is the last section's x (x1).
struct Cascade {
  Eigen::MatrixXd a;
  Eigen::VectorXd b, c;
};

Cascade analog_cascade(const std::vector<AnalogFilter>& filters) {
  std::vector<dsp::AnalogSection> sections;
  for (const AnalogFilter& f : filters) {
    if (f.order == 0) continue;
    for (const dsp::AnalogSection& s : dsp::analog_butterworth_lowpass(f.order, f.cutoff_hz)) sections.push_back(s);
  }
  int n = 0;
  for (const dsp::AnalogSection& s : sections) n += s.first_order ? 1 : 2;
  Cascade out{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n)};
  int p = 0, input = -1;  // input: the state feeding this section (−1: the drive)
  for (const dsp::AnalogSection& s : sections) {
    const auto feed = [&](int row, double gain) {
      if (input < 0) {
        out.b[row] += gain;
      } else {
        out.a(row, input) += gain;
      }
    };
    if (s.first_order) {
      out.a(p, p) = -s.omega;
      feed(p, s.omega);
      input = p;
      p += 1;
    } else {
      const double w2 = s.omega * s.omega;
      out.a(p, p + 1) = 1.0;
      out.a(p + 1, p) = -w2;
      out.a(p + 1, p + 1) = -s.omega / s.q;
      feed(p + 1, w2);
      input = p;
      p += 2;
    }
  }
  if (input >= 0) out.c[input] = 1.0;
  return out;
}

}  // namespace

Eigen::VectorXd converters_alone(const PlantConfig& plant, const Eigen::VectorXd& drive) {
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    if (!std::isfinite(drive[k])) throw std::invalid_argument("converters: drive sample " + std::to_string(k) + " is not finite");
  }
  const Cascade cascade = analog_cascade({plant.converters.da_filter, plant.converters.ad_filter});
  const auto delay = static_cast<Eigen::Index>(plant.converters.delay_samples);
  Eigen::VectorXd out = Eigen::VectorXd::Zero(drive.size());
  const Eigen::Index n = cascade.a.rows();
  if (n == 0) {  // no filters: the delay alone
    for (Eigen::Index k = delay; k < drive.size(); ++k) out[k] = drive[k - delay];
    return out;
  }
  // [Ad Bd; 0 1] = exp([A B; 0 0]·T): the zero-order-hold discretisation.
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(n + 1, n + 1);
  augmented.topLeftCorner(n, n) = cascade.a / plant.fs;
  augmented.topRightCorner(n, 1) = cascade.b / plant.fs;
  const Eigen::MatrixXd held = augmented.exp();
  const Eigen::MatrixXd ad = held.topLeftCorner(n, n);
  const Eigen::VectorXd bd = held.topRightCorner(n, 1);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n);
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    // The drive sample held over this period is the one `delay` samples back; the output is sampled at
    // the period's end.
    const double u = k >= delay ? drive[k - delay] : 0.0;
    next.noalias() = ad * x + bd * u;
    x.swap(next);
    out[k] = cascade.c.dot(x);
  }
  return out;
}

}  // namespace panelbass::models
