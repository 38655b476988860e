#include "usecases/design_mirror.h"

#include <cmath>

#include "models/control/mirror_current_fit.h"
#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

using models::number_text;

void check(const DesignMirrorRequest& q) {
  if (!(std::isfinite(q.fs) && q.fs > 0.0)) throw RequestError("fs", "must be > 0 Hz, got " + number_text(q.fs));
  if (q.current.size() != q.drive.size() || (!q.current_only && q.displacement.size() != q.drive.size())) {
    throw RequestError("record", "the drive, current and displacement must be equally long (" +
                                     std::to_string(q.drive.size()) + ", " + std::to_string(q.current.size()) + ", " +
                                     std::to_string(q.displacement.size()) + " samples)");
  }
  if (q.drive.size() < 1000) {
    throw RequestError("record", "needs at least 1000 samples, got " + std::to_string(q.drive.size()));
  }
  if (q.max_delay < 0 || q.max_delay > 64) {
    throw RequestError("max_delay", "must be within 0..64, got " + std::to_string(q.max_delay));
  }
  try {
    (void)models::mirror_sensor_kind(q.sensor_kind);
  } catch (const std::invalid_argument& e) {
    throw RequestError("sensor_kind", e.what());
  }
  if (q.sensor_kind != "none" && !q.current_only) {
    throw RequestError("sensor_kind", "a sensor joins the fit only with current_only (the displacement fit reads none)");
  }
  if (q.sensor_kind != "none" && q.sensor.size() != q.drive.size()) {
    throw RequestError("sensor_kind", "needs the sensor's output, as long as the drive (" + std::to_string(q.sensor.size()) +
                                          " samples given)");
  }
  if (q.adapt && !q.current_only && q.sensor.size() != q.drive.size()) {
    throw RequestError("adapt", "needs the sensor's output, as long as the drive (" + std::to_string(q.sensor.size()) +
                                    " samples given)");
  }
  if (!(std::isfinite(q.stiffness_rate) && q.stiffness_rate >= 0.0)) {
    throw RequestError("stiffness_rate", "must be ≥ 0, got " + number_text(q.stiffness_rate));
  }
  if (!(std::isfinite(q.stiffness_spread) && q.stiffness_spread > 0.0)) {
    throw RequestError("stiffness_spread", "must be > 0, got " + number_text(q.stiffness_spread));
  }
}

nlohmann::json to_json(const DesignMirrorRequest& q) {
  return {{"record", q.data_name},         {"samples", q.drive.size()},          {"fs", q.fs},
          {"max_delay", q.max_delay},      {"adapt", q.adapt},                   {"stiffness_rate", q.stiffness_rate},
          {"stiffness_spread", q.stiffness_spread}, {"current_only", q.current_only}, {"sensor_kind", q.sensor_kind}};
}

namespace {

/// The current-only fit (models/control/mirror_current_fit.h): J per channel on validation, and a fit that misses
/// the current (J_val over kMirrorFitWarningPct) said so and marked not usable.
DesignMirrorReport design_mirror_from_current(const DesignMirrorRequest& q, Progress& progress) {
  progress.report(0.0, "fitting [M1]-[M3] to the drive and the current (the motion from the back-EMF)");
  models::MirrorCurrentFitOptions options;
  options.max_delay = q.max_delay;
  options.sensor_kind = models::mirror_sensor_kind(q.sensor_kind);
  const Eigen::VectorXd no_sensor;
  const models::MirrorCurrentFit fit = models::fit_mirror_model_from_current(
      q.drive, q.current, q.fs, options, options.sensor_kind == models::MirrorSensorKind::none ? no_sensor : q.sensor);
  DesignMirrorReport report;
  report.model = fit.model;
  if (q.adapt) {
    // adapting from the current (mirror_current_adapter.h): the fit's lag, and its current error as the noise
    if (fit.current_lag < -1 || fit.current_lag > 6) {
      throw RequestError("adapt", "the current's lag behind the drive (" + std::to_string(fit.current_lag) +
                                      " samples) is outside the −1..6 the adaptation takes");
    }
    models::MirrorObserverSettings& o = report.model.observer;
    o.enabled = true;
    o.measurement = models::MirrorMeasurement::current;
    o.current_lag = fit.current_lag;
    const double current_rms = std::sqrt(q.current.squaredNorm() / static_cast<double>(q.current.size()));
    o.current_noise = std::max(std::sqrt(fit.current_j_val_pct / 100.0), 1e-3) * current_rms;
  }
  const nlohmann::json sensor_j = fit.sensor_j_val_pct >= 0.0 ? nlohmann::json(fit.sensor_j_val_pct) : nlohmann::json(nullptr);
  report.meta = {{"data", q.data_name},
                 {"current_only", true},
                 {"current_j_val_pct", fit.current_j_val_pct},
                 {"sensor_j_val_pct", sensor_j},
                 {"displacement_units", "rms 1 on the record (the current does not tell the scale of x)"}};
  if (!(fit.current_j_val_pct <= kMirrorFitWarningPct)) {
    report.usable = false;
    report.warnings.push_back("the current's free-run J on validation is " + number_text(fit.current_j_val_pct, 3) +
                              " % (over " + number_text(kMirrorFitWarningPct) +
                              " %): the gray-box model misses this transducer; its mirror filter is not to be used "
                              "(check the record's columns: drive and coil current in A, one rate)");
  }
  if (!(fit.current_j_val_pct < fit.linear_j_val_pct)) {
    report.warnings.push_back("the nonlinear model's current J on validation (" + number_text(fit.current_j_val_pct, 3) +
                              " %) is no better than the linear one's (" + number_text(fit.linear_j_val_pct, 3) +
                              " %): the record shows no distortion the model can name");
  }
  report.summary = {{"fs", fit.model.fs},
                    {"current_only", true},
                    {"usable", report.usable},
                    {"delay", fit.model.delay},
                    {"current_lag", fit.current_lag},
                    {"resonance_hz", fit.resonance_hz},
                    {"friction_velocity_mm_per_s", fit.model.friction_velocity},
                    {"electrical", fit.model.electrical},
                    {"mechanical", fit.model.mechanical},
                    {"drive_taps", fit.model.drive_taps},
                    {"linear_current_j_val_pct", fit.linear_j_val_pct},
                    {"current_j_fit_pct", fit.current_j_fit_pct},
                    {"current_j_val_pct", fit.current_j_val_pct},
                    {"sensor_kind", q.sensor_kind},
                    {"sensor_j_val_pct", sensor_j},
                    {"sensor_delay", fit.sensor_j_val_pct >= 0.0 ? nlohmann::json(fit.sensor_delay) : nlohmann::json(nullptr)},
                    {"sensor_taps", fit.sensor_j_val_pct >= 0.0 ? nlohmann::json(fit.sensor_taps) : nlohmann::json(nullptr)},
                    {"iterations", fit.iterations},
                    {"force_factor_asymmetry", fit.force_factor_asymmetry},
                    {"damping_rise", fit.damping_rise},
                    {"adaptive", q.adapt},
                    {"adapts_from", q.adapt ? "current" : "none"}};
  progress.report(1.0, "done");
  return report;
}

}  // namespace

DesignMirrorReport design_mirror(const DesignMirrorRequest& q, Progress& progress) {
  check(q);
  if (q.current_only) return design_mirror_from_current(q, progress);
  progress.report(0.0, "fitting the gray-box model [M1]-[M3]");
  models::MirrorFit fit = models::fit_mirror_model(q.drive, q.current, q.displacement, q.fs, q.max_delay);
  DesignMirrorReport report;
  report.meta = {{"data", q.data_name},
                 {"electrical_fit_pct", fit.electrical_fit_pct},
                 {"mechanical_fit_pct", fit.mechanical_fit_pct}};
  if (q.adapt) {
    progress.report(0.7, "fitting the sensor map");
    if (fit.model.delay > models::MirrorObserver::kMaxDelay) {
      throw RequestError("adapt", "the fitted drive delay (" + std::to_string(fit.model.delay) +
                                      " samples) exceeds the observer's " + std::to_string(models::MirrorObserver::kMaxDelay));
    }
    const models::SensorMapFit sensor = models::fit_sensor_map(q.displacement, q.sensor, q.fs);
    models::MirrorObserverSettings& s = fit.model.observer;
    s.enabled = true;
    s.sensor_taps = sensor.taps;
    s.sensor_noise = sensor.noise_rms;
    s.process_noise = fit.mechanical_residual_rms;
    s.stiffness_rate = q.stiffness_rate;
    s.stiffness_spread = q.stiffness_spread;
    report.meta["sensor_map_residual_rms"] = sensor.noise_rms;
  }
  for (const auto& [name, pct] : {std::pair{"electrical", fit.electrical_fit_pct}, std::pair{"mechanical", fit.mechanical_fit_pct}}) {
    if (!(pct <= kMirrorFitWarningPct)) {
      report.warnings.push_back(std::string("the ") + name + " equation's residual is " + number_text(pct, 3) +
                                " % of its signal (over " + number_text(kMirrorFitWarningPct) +
                                " %): the gray-box model misses this transducer, and its mirror filter may add distortion "
                                "instead of cutting it; check the record's columns (current in A, displacement in m, "
                                "aligned to the drive) and judge the filter with verify before using it");
    }
  }
  report.model = fit.model;
  report.summary = {{"fs", fit.model.fs},
                    {"delay", fit.model.delay},
                    {"friction_velocity_mm_per_s", fit.model.friction_velocity},
                    {"electrical", fit.model.electrical},
                    {"mechanical", fit.model.mechanical},
                    {"electrical_fit_pct", fit.electrical_fit_pct},
                    {"mechanical_fit_pct", fit.mechanical_fit_pct},
                    {"adaptive", fit.model.observer.enabled},
                    {"sensor_map_residual_rms", report.meta.value("sensor_map_residual_rms", nlohmann::json(nullptr))}};
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases
