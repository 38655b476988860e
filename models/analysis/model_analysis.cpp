#include "models/analysis/model_analysis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <variant>

#include "dsp/decibels.h"
#include "dsp/spectrum.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/roots_json.h"
#include "models/linear/oe_estimator.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

json vector_json(const Eigen::VectorXd& v) {
  json out = json::array();
  for (Eigen::Index k = 0; k < v.size(); ++k) out.push_back(number_or_null(v[k]));
  return out;
}

Eigen::VectorXd centred(const Eigen::VectorXd& x) { return x.array() - x.mean(); }

std::size_t welch_segment(std::size_t requested, Eigen::Index samples) {
  if (requested > 0) {
    if (requested > static_cast<std::size_t>(samples)) {
      throw std::invalid_argument("analysis: the Welch segment (" + std::to_string(requested) + ") is longer than the " +
                                  std::to_string(samples) + " samples judged");
    }
    return requested;
  }
  if (samples / 4 < 64) {
    throw std::invalid_argument("analysis: " + std::to_string(samples) +
                                " samples after init are too few for spectra (at least 256 needed)");
  }
  // Long segments (up to 4096): a segment not much longer than the impulse response leaks, which lowers the
  // coherence and raises the non-coherent floor.
  return dsp::welch_segment(samples, 4096);
}

json loop_json(const ClosedLoop& loop) {
  return {{"gain", loop.gain},
          {"max_radius", number_or_null(loop.max_radius)},
          {"impulse_length", number_or_null(loop.impulse_length)},
          {"stable", loop.stable}};
}

json rows_json(const std::vector<DistortionRow>& rows) {
  json out = json::array();
  for (const DistortionRow& r : rows) {
    json h = json::array();
    for (const double db : r.harmonic_db) h.push_back(number_or_null(db));
    out.push_back({{"frequency_hz", r.frequency},
                   {"amplitude", r.amplitude},
                   {"fundamental", r.fundamental},
                   {"harmonic_db", h},
                   {"thd_pct", number_or_null(r.thd_percent)}});
  }
  return out;
}

json test_json(const CorrelationTest& t) {
  return {{"name", t.name},
          {"verdict", t.passes ? "pass" : "fail"},
          {"passes", t.passes},
          {"outside", t.outside},
          {"allowed_outside", t.allowed_outside},
          {"lags", t.lags.size()},
          {"fraction_outside", t.fraction_outside},
          {"band", t.band},
          {"peak", t.peak},
          {"peak_band", t.peak_band},
          {"values", vector_json(t.values)},
          {"first_lag", t.lags.empty() ? 0 : t.lags.front()}};
}

// [2A] J per OE iteration: ŷ_raw − y_raw = y_scale·(ŷ − y) in scaled units, so J = y_scale²·V·M / Σ y_raw².
TrainingHistory refinement_history(const LinearModel& lm, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                   Eigen::Index init, int iterations) {
  OeOptions options;
  options.max_iterations = iterations;
  options.transient_skip = init;
  const OeResult fit = estimate_oe(lm.scaling.scale_u(u), lm.scaling.scale_y(y), lm.tf, options);
  const Eigen::Index m = y.size() - init;
  const double energy = y.tail(m).squaredNorm();
  const double scale2 = lm.scaling.y_scale * lm.scaling.y_scale;
  TrainingHistory h;
  h.source = "OE refinement of the model on the analysed data (from rest, first " + std::to_string(init) +
             " samples skipped)";
  for (std::size_t i = 0; i < fit.history.size(); ++i) {
    HistoryPoint p;
    p.iteration = static_cast<int>(i);
    p.mode = "oe";
    p.j_est_pct = j_ratio_percent(scale2 * fit.history[i] * static_cast<double>(m), energy);  // the OE loss is a mean
    h.points.push_back(p);
  }
  return h;
}

PoleZeroAnalysis pole_zero_analysis(const LinearModel& lm, const Eigen::VectorXd& frequency, const AnalysisSpec& spec) {
  PoleZeroAnalysis pz;
  pz.poles = lm.tf.poles();
  pz.zeros = lm.tf.zeros();
  // Raw gain k ↔ scaled gain k·y_scale/u_scale (root_locus(LinearModel, …)).
  const double to_scaled = lm.scaling.y_scale / lm.scaling.u_scale;
  double k_min = spec.gain_min * to_scaled, k_max = spec.gain_max * to_scaled;
  if (!std::isfinite(k_min) || !std::isfinite(k_max)) {
    // |k|·‖G‖∞ < 1 keeps the loop stable (small gain) but is conservative: from there, double each bound
    // until the loop is unstable, so the range holds the whole stable interval around k = 0.
    double peak = 0.0;
    for (Eigen::Index i = 0; i < frequency.size(); ++i) peak = std::max(peak, std::abs(lm.tf.response(frequency[i], lm.fs)));
    if (!(peak > 0.0)) throw std::invalid_argument("analysis: the model's frequency response is zero");
    const auto unstable_bound = [&](double k) {
      for (int i = 0; i < 20 && closed_loop(lm.tf, k).max_radius < 1.0; ++i) k *= 2.0;
      return k;
    };
    if (!std::isfinite(k_min)) k_min = unstable_bound(-1.0 / peak);
    if (!std::isfinite(k_max)) k_max = unstable_bound(1.0 / peak);
  }
  if (!(k_max > k_min)) throw std::invalid_argument("analysis: the root-locus gain range is empty");
  const ShortestImpulse found = shortest_impulse_gain(lm.tf, k_min, k_max, spec.gain_points);
  std::vector<double> gains;
  for (const ClosedLoop& loop : found.grid) gains.push_back(loop.gain / to_scaled);
  pz.locus = root_locus(lm, gains);
  pz.gain_min = k_min / to_scaled;
  pz.gain_max = k_max / to_scaled;
  pz.open_loop = closed_loop(lm.tf, 0.0);
  pz.best = found.best;
  pz.best_gain_scaled = found.best.gain;
  pz.best.gain = found.best.gain / to_scaled;
  return pz;
}

// A number or null in a history entry.
double history_number(const json& entry, const std::string& key, const std::string& path, bool required) {
  if (!entry.contains(key)) {
    if (required) throw ConfigError(path + "." + key + ": missing");
    return kNaN;
  }
  const json& v = entry.at(key);
  if (v.is_null()) return kNaN;
  if (!v.is_number()) throw ConfigError(path + "." + key + ": not a number");
  return v.get<double>();
}

}  // namespace

namespace {

// J_sim above this multiple of the sensor noise's J: the residual is model error, not noise.
constexpr double kModelErrorRatio = 3.0;

// What the figures add to the residual tests' reading: a simulation residual far above the sensor noise is
// model error whatever its colour, and a coherence figure the model beats is no floor.
std::string residual_verdict(const ModelAnalysis& a) {
  std::string out;
  char text[400];
  if (std::isfinite(a.j_noise_pct) && a.j_noise_pct > 0.0 && a.j_sim_pct > kModelErrorRatio * a.j_noise_pct) {
    std::snprintf(text, sizeof text,
                  "; J_sim is %.3g times the sensor noise's J (%.3g %%): the residual is mostly model error (a "
                  "nonlinearity or missing dynamics), not noise",
                  a.j_sim_pct / a.j_noise_pct, a.j_noise_pct);
    out += text;
  }
  if (a.j_sim_pct < a.j_noncoherent_pct) {
    std::snprintf(text, sizeof text,
                  "; the model's J_sim is below J_noncoherent (%.3g %%), so that figure is no floor here: spectral leakage "
                  "of a response long against the %zu-sample Welch segment inflates it",
                  a.j_noncoherent_pct, a.spectrum.segment);
    out += text;
  }
  return out;
}

}  // namespace

ModelAnalysis analyze_model(const AnyModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            const AnalysisSpec& spec, std::optional<TrainingHistory> given_history) {
  const auto progress = [&](const char* stage, double f) {
    if (spec.progress) spec.progress(stage, f);
  };
  if (u.size() != y.size()) throw std::invalid_argument("analysis: input and output differ in length");
  if (spec.init < 0 || spec.init >= u.size()) {
    throw std::invalid_argument("analysis: init " + std::to_string(spec.init) + " is not shorter than the " +
                                std::to_string(u.size()) + " samples");
  }
  ModelAnalysis a;
  a.kind = model.kind();
  a.fs = model.fs();
  a.init = spec.init;
  const Eigen::Index m = u.size() - spec.init;
  a.samples = m;

  progress("simulate", 0.0);
  const Eigen::VectorXd y_sim = model.simulate(u, y, spec.init);
  const Eigen::VectorXd y_pred = model.predict(u, y);
  a.j_sim_pct = j_percent(y_sim, y, spec.init);
  a.j_pred_pct = j_percent(y_pred, y, spec.init);
  a.u = u.tail(m);
  a.y = y.tail(m);
  a.y_sim = y_sim.tail(m);
  const Eigen::VectorXd residual = a.y - a.y_sim;
  a.rmse = std::sqrt(residual.squaredNorm() / static_cast<double>(m));

  progress("residual tests", 0.15);
  a.residual_tests = residual_tests(a.u, residual, spec.max_lag);

  progress("spectra", 0.25);
  dsp::WelchSpec welch;
  welch.segment = welch_segment(spec.segment, m);
  const Eigen::VectorXd uc = centred(a.u), yc = centred(a.y);
  const dsp::PowerSpectrum s_yy = dsp::welch_psd(yc, a.fs, welch);
  const dsp::PowerSpectrum s_ee = dsp::welch_psd(centred(residual), a.fs, welch);
  const dsp::FrequencyResponse h1 = dsp::h1_frf(uc, yc, a.fs, welch);
  ResidualSpectrum& spectrum = a.spectrum;
  spectrum.segment = welch.segment;
  spectrum.frequency = s_yy.frequency;
  spectrum.output_psd = s_yy.psd;
  spectrum.residual_psd = s_ee.psd;
  spectrum.noncoherent_psd.resize(s_yy.psd.size());
  // Averaging biases γ̂² up: E[γ̂²] ≈ γ² + (1 − γ²)²/n_d (Bendat & Piersol, Random Data, ch. 9), so
  // x̂ = 1 − γ̂² ≈ x·(1 − x/n_d) and x = (n_d − √(n_d·(n_d − 4·x̂)))/2. n_d = K/(1 + 2ρ²) for K Hann
  // segments at 50 % overlap, ρ = 0.167 the correlation of neighbouring segments (Welch 1967).
  const auto hop = static_cast<Eigen::Index>(welch.segment - static_cast<std::size_t>(std::lround(welch.overlap * welch.segment)));
  const double segments = static_cast<double>((m - static_cast<Eigen::Index>(welch.segment)) / std::max<Eigen::Index>(hop, 1) + 1);
  const double n_d = segments / (1.0 + 2.0 * 0.167 * 0.167);
  for (Eigen::Index k = 0; k < s_yy.psd.size(); ++k) {
    const double g = h1.coherence[k];
    double x = std::isfinite(g) ? std::clamp(1.0 - g, 0.0, 1.0) : 1.0;
    if (n_d >= 4.0) x = std::min(1.0, 0.5 * (n_d - std::sqrt(n_d * std::max(0.0, n_d - 4.0 * x))));
    spectrum.noncoherent_psd[k] = x * s_yy.psd[k];
  }
  const double df = a.fs / static_cast<double>(welch.segment);
  const double mean_square = a.y.squaredNorm() / static_cast<double>(m);
  // The J of a perfect model: the output's power no model of the input explains (per sample, as the mean square).
  a.j_noncoherent_pct = j_ratio_percent(spectrum.noncoherent_psd.sum() * df, mean_square);
  if (spec.plant) {
    const double sigma = spec.plant->sensor.noise_rms_V;
    spectrum.sensor_noise_psd = 2.0 * sigma * sigma / a.fs;  // white: σ² spread evenly over 0..fs/2
    a.j_noise_pct = j_ratio_percent(sigma * sigma, mean_square);
  }

  a.frf.frequency = h1.frequency;
  a.frf.measured = h1.h;
  a.frf.coherence = h1.coherence;
  const LinearModel* lm = std::get_if<LinearModel>(&model.model);
  if (lm != nullptr) {
    a.frf.model_source = "transfer function";
    const double gain = lm->scaling.y_scale / lm->scaling.u_scale;
    a.frf.model.resize(h1.frequency.size());
    for (Eigen::Index k = 0; k < h1.frequency.size(); ++k) a.frf.model[k] = gain * lm->tf.response(h1.frequency[k], a.fs);
  } else {
    a.frf.model_source = "H1 of the simulated output";
    a.frf.model = dsp::h1_frf(uc, centred(a.y_sim), a.fs, welch).h;
  }

  if (lm != nullptr) {
    progress("root locus", 0.35);
    a.pole_zero = pole_zero_analysis(*lm, h1.frequency, spec);
  }

  progress("training history", 0.45);
  if (given_history) {
    a.history = std::move(given_history);
  } else if (lm != nullptr && spec.refine_iterations > 0) {
    a.history = refinement_history(*lm, u, y, spec.init, spec.refine_iterations);
  }

  if (spec.plant) {
    progress("harmonic distortion", 0.6);
    a.distortion = compare_distortion(*spec.plant, model, spec.distortion);
    a.distortion_amplitudes = spec.distortion.amplitudes;
  }
  a.residual_tests.explanation += residual_verdict(a);
  progress("done", 1.0);
  return a;
}

std::optional<TrainingHistory> training_history_from_json(const json& j, const std::string& where) {
  const json* list = nullptr;
  std::string path = where;
  if (j.is_array()) {
    list = &j;
  } else if (j.is_object() && j.contains("history")) {
    list = &j.at("history");
    path += ": history";
  } else if (j.is_object() && j.contains("meta") && j.at("meta").is_object() && j.at("meta").contains("history")) {
    list = &j.at("meta").at("history");
    path += ": meta.history";
  }
  if (list == nullptr) return std::nullopt;
  if (!list->is_array()) throw ConfigError(path + ": not an array");
  TrainingHistory h;
  h.source = path;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const json& entry = list->at(i);
    const std::string at = path + "[" + std::to_string(i) + "]";
    if (!entry.is_object()) throw ConfigError(at + ": not an object");
    HistoryPoint p;
    const double iteration = history_number(entry, "iter", at, false);
    p.iteration = std::isfinite(iteration) ? static_cast<int>(iteration) : static_cast<int>(i);
    p.j_est_pct = history_number(entry, "J_est_pct", at, true);
    p.j_val_pct = history_number(entry, "J_val_pct", at, false);
    if (entry.contains("mode")) {
      if (!entry.at("mode").is_string()) throw ConfigError(at + ".mode: not a string");
      p.mode = entry.at("mode").get<std::string>();
    }
    h.points.push_back(p);
  }
  if (h.points.empty()) return std::nullopt;
  return h;
}

json analysis_to_json(const ModelAnalysis& a) {
  const ResidualTests& r = a.residual_tests;
  json tests = json::array();
  for (const CorrelationTest* t : {&r.ee, &r.ue, &r.u2e, &r.u2e2, &r.e_eu}) tests.push_back(test_json(*t));

  const ResidualSpectrum& s = a.spectrum;
  const double floor_sum = s.noncoherent_psd.sum();
  json spectrum = {{"segment", s.segment},
                   {"resolution_hz", a.fs / static_cast<double>(s.segment)},
                   {"residual_over_noncoherent_db",
                    floor_sum > 0.0 ? number_or_null(10.0 * std::log10(s.residual_psd.sum() / floor_sum)) : json(nullptr)},
                   {"sensor_noise_psd", number_or_null(s.sensor_noise_psd)},
                   {"frequency_hz", vector_json(s.frequency)},
                   {"output_psd", vector_json(s.output_psd)},
                   {"residual_psd", vector_json(s.residual_psd)},
                   {"noncoherent_psd", vector_json(s.noncoherent_psd)}};

  // How far the model's response is from the measured one where the measurement is trustworthy.
  const Eigen::VectorXd measured_db = dsp::magnitude_db(a.frf.measured), model_db = dsp::magnitude_db(a.frf.model);
  double squared = 0.0;
  int coherent = 0;
  for (Eigen::Index k = 1; k < measured_db.size(); ++k) {
    if (a.frf.coherence[k] >= 0.9 && std::isfinite(measured_db[k]) && std::isfinite(model_db[k])) {
      squared += (model_db[k] - measured_db[k]) * (model_db[k] - measured_db[k]);
      ++coherent;
    }
  }
  json frf = {{"model_source", a.frf.model_source},
              {"mean_coherence", a.frf.coherence.size() > 1 ? a.frf.coherence.tail(a.frf.coherence.size() - 1).mean() : kNaN},
              {"coherent_bins", coherent},
              {"rms_error_db_where_coherent", coherent > 0 ? number_or_null(std::sqrt(squared / coherent)) : json(nullptr)},
              {"frequency_hz", vector_json(a.frf.frequency)},
              {"measured_db", vector_json(measured_db)},
              {"model_db", vector_json(model_db)},
              {"coherence", vector_json(a.frf.coherence)}};

  json out = {{"kind", a.kind},
              {"fs", a.fs},
              {"samples", a.samples},
              {"init", a.init},
              {"J_sim_pct", a.j_sim_pct},
              {"J_pred_pct", a.j_pred_pct},
              {"rmse", a.rmse},
              {"J_noncoherent_pct", a.j_noncoherent_pct},
              {"J_noise_pct", number_or_null(a.j_noise_pct)},
              {"residual_tests",
               {{"passes", r.passes},
                {"input_tests_pass", r.input_tests_pass},
                {"verdict", r.passes ? "pass" : "fail"},
                {"explanation", r.explanation},
                {"tests", tests}}},
              {"residual_spectrum", spectrum},
              {"frf", frf}};

  if (a.pole_zero) {
    const PoleZeroAnalysis& pz = *a.pole_zero;
    json gains = json::array(), radii = json::array();
    for (const ClosedLoop& loop : pz.locus) {
      gains.push_back(loop.gain);
      radii.push_back(number_or_null(loop.max_radius));
    }
    json best = loop_json(pz.best);
    best["gain_scaled"] = pz.best_gain_scaled;
    best["poles"] = roots_json(pz.best.poles);
    out["poles"] = roots_json(pz.poles);
    out["zeros"] = roots_json(pz.zeros);
    out["root_locus"] = {{"feedback", "u = r - k*y (raw units)"},
                         {"gain_min", pz.gain_min},
                         {"gain_max", pz.gain_max},
                         {"open_loop", loop_json(pz.open_loop)},
                         {"best", best},
                         {"gains", gains},
                         {"max_radius", radii}};
  } else {
    out["poles"] = nullptr;
    out["zeros"] = nullptr;
    out["root_locus"] = nullptr;
  }

  if (a.history) {
    json points = json::array();
    for (const HistoryPoint& p : a.history->points) {
      points.push_back({{"iter", p.iteration}, {"mode", p.mode}, {"J_est_pct", number_or_null(p.j_est_pct)},
                        {"J_val_pct", number_or_null(p.j_val_pct)}});
    }
    out["training_history"] = {{"source", a.history->source}, {"points", points}};
  } else {
    out["training_history"] = nullptr;
  }

  if (a.distortion) {
    out["distortion"] = {{"amplitudes", a.distortion_amplitudes},
                         {"plant", rows_json(a.distortion->plant)},
                         {"model", rows_json(a.distortion->model)}};
  } else {
    out["distortion"] = nullptr;
  }
  return out;
}

}  // namespace panelbass::models
