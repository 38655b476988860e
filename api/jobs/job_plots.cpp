#include "api/jobs/job_plots.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/decibels.h"
#include "dsp/spectrum.h"
#include "models/io/json_fields.h"

namespace panelbass::api {

using nlohmann::json;


json without_non_finite(const json& value) {
  if (value.is_number_float()) return models::number_or_null(value.get<double>());
  if (value.is_array() || value.is_object()) {
    json out = value;
    for (auto& element : out) element = without_non_finite(element);
    return out;
  }
  return value;
}

json column(const Eigen::VectorXd& x) {
  json out = json::array();
  for (Eigen::Index k = 0; k < x.size(); ++k) out.push_back(models::number_or_null(x[k]));
  return out;
}

json fit_plot(const Eigen::VectorXd& measured, const Eigen::VectorXd& simulated, double fs, Eigen::Index first_sample,
              Eigen::Index max_points) {
  if (measured.size() != simulated.size()) throw std::invalid_argument("fit plot: measured and simulated lengths differ");
  const Eigen::Index n = std::min(measured.size(), max_points);
  const Eigen::VectorXd t = (Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1)).array() + first_sample) / fs;
  return {{"t", column(t)}, {"measured", column(measured.head(n))}, {"simulated", column(simulated.head(n))}};
}

json spectrum_plot(const Eigen::VectorXd& f, const Eigen::VectorXcd& measured, const Eigen::VectorXcd& model) {
  if (f.size() != measured.size() || f.size() != model.size()) throw std::invalid_argument("spectrum plot: lengths differ");
  std::vector<Eigen::Index> bins;
  for (Eigen::Index k = 0; k < f.size(); ++k) {
    if (f[k] > 0.0) bins.push_back(k);
  }
  Eigen::VectorXd fk(bins.size());
  Eigen::VectorXcd mk(bins.size()), hk(bins.size());
  for (std::size_t i = 0; i < bins.size(); ++i) {
    fk[i] = f[bins[i]];
    mk[i] = measured[bins[i]];
    hk[i] = model[bins[i]];
  }
  return {{"f", column(fk)}, {"measured_db", column(dsp::magnitude_db(mk))}, {"model_db", column(dsp::magnitude_db(hk))}};
}

json spectrum_plot(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& y_model, double fs) {
  if (u.size() != y.size() || u.size() != y_model.size()) throw std::invalid_argument("spectrum plot: lengths differ");
  if (u.size() < 64) throw std::invalid_argument("spectrum plot: fewer than 64 samples");
  dsp::WelchSpec spec;
  spec.segment = dsp::welch_segment(u.size());
  const dsp::FrequencyResponse measured = dsp::h1_frf(u, y, fs, spec);
  const dsp::FrequencyResponse model = dsp::h1_frf(u, y_model, fs, spec);
  return spectrum_plot(measured.frequency, measured.h, model.h);
}

json residual_spectrum_plot(const Eigen::VectorXd& residual_before, const Eigen::VectorXd& residual_after,
                            double noise_psd, double fs) {
  if (residual_before.size() != residual_after.size()) throw std::invalid_argument("residual spectrum plot: lengths differ");
  if (residual_before.size() < 64) throw std::invalid_argument("residual spectrum plot: fewer than 64 samples");
  dsp::WelchSpec spec;
  spec.segment = dsp::residual_welch_segment(residual_before.size());  // as the diagnosis reads the residual
  const dsp::PowerSpectrum before = dsp::welch_psd(residual_before, fs, spec);
  const dsp::PowerSpectrum after = dsp::welch_psd(residual_after, fs, spec);
  const Eigen::Index n = before.frequency.size() - 1;  // DC left out
  const double floor_db = noise_psd > 0.0 ? 10.0 * std::log10(noise_psd) : std::nan("");
  return {{"frequency_hz", column(before.frequency.tail(n))},
          {"before_db", column(dsp::power_db(before.psd.tail(n)))},
          {"after_db", column(dsp::power_db(after.psd.tail(n)))},
          {"noise_floor_db", column(Eigen::VectorXd::Constant(n, floor_db))}};
}

json history_plot(const std::vector<HistoryPoint>& points) {
  json iteration = json::array(), est = json::array(), val = json::array();
  for (const HistoryPoint& p : points) {
    iteration.push_back(p.iteration);
    est.push_back(models::number_or_null(p.j_est_pct));
    val.push_back(models::number_or_null(p.j_val_pct));
  }
  return {{"iteration", iteration}, {"j_est_pct", est}, {"j_val_pct", val}};
}

json harmonics_plot(const models::DistortionComparison& comparison) {
  json f = json::array(), ph2 = json::array(), ph3 = json::array(), mh2 = json::array(), mh3 = json::array();
  const auto level = [](const models::DistortionRow& row, std::size_t index) {
    return index < row.harmonic_db.size() ? models::number_or_null(row.harmonic_db[index]) : json(nullptr);
  };
  const std::size_t n = std::min(comparison.plant.size(), comparison.model.size());
  for (std::size_t k = 0; k < n; ++k) {
    f.push_back(models::number_or_null(comparison.plant[k].frequency));
    ph2.push_back(level(comparison.plant[k], 0));
    ph3.push_back(level(comparison.plant[k], 1));
    mh2.push_back(level(comparison.model[k], 0));
    mh3.push_back(level(comparison.model[k], 1));
  }
  return {{"f", f}, {"measured_h2_db", ph2}, {"measured_h3_db", ph3}, {"model_h2_db", mh2}, {"model_h3_db", mh3}};
}

}  // namespace panelbass::api
