#include "models/plant/converter_loop.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "dsp/butterworth.h"

namespace panelbass::models {

std::vector<ConverterSection> converter_sections(const AnalogFilter& filter, int& next) {
  std::vector<ConverterSection> out;
  if (filter.order == 0) return out;
  for (const dsp::AnalogSection& s : dsp::analog_butterworth_lowpass(filter.order, filter.cutoff_hz)) {
    out.push_back(ConverterSection{s, next});
    next += s.first_order ? 1 : 2;
  }
  return out;
}

double converter_derivatives(const std::vector<ConverterSection>& sections, const Eigen::VectorXd& s, double in,
                             Eigen::VectorXd& ds) noexcept {
  double signal = in;
  for (const ConverterSection& sec : sections) {
    const int p = sec.state;
    if (sec.first_order) {
      ds[p] = sec.omega * (signal - s[p]);
    } else {
      ds[p] = s[p + 1];
      ds[p + 1] = sec.omega * sec.omega * (signal - s[p]) - sec.omega / sec.q * s[p + 1];
    }
    signal = s[p];
  }
  return signal;
}

namespace {

// The continuous-time cascade of the DA and AD filters in state-space form, x' = A·x + b·u, output c·x: the
// columns of converter_derivatives (which is linear in the state and the input) at each unit state and input.
struct Cascade {
  Eigen::MatrixXd a;
  Eigen::VectorXd b, c;
};

Cascade analog_cascade(const PlantConfig& plant) {
  int n = 0;
  std::vector<ConverterSection> sections = converter_sections(plant.converters.da_filter, n);
  for (const ConverterSection& s : converter_sections(plant.converters.ad_filter, n)) sections.push_back(s);
  Cascade out{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n)};
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(n), ds = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    unit.setZero();
    unit[j] = 1.0;
    out.c[j] = converter_derivatives(sections, unit, 0.0, ds);
    out.a.col(j) = ds;
  }
  unit.setZero();
  converter_derivatives(sections, unit, 1.0, ds);
  out.b = ds;
  return out;
}

}  // namespace

Eigen::VectorXd converters_alone(const PlantConfig& plant, const Eigen::VectorXd& drive) {
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    if (!std::isfinite(drive[k])) throw std::invalid_argument("converters: drive sample " + std::to_string(k) + " is not finite");
  }
  const Cascade cascade = analog_cascade(plant);
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
