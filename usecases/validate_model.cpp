#include "usecases/validate_model.h"

#include <cmath>
#include <cstdio>

#include "models/validation/performance.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

/// Why a one-step prediction J can be worse than the simulation J, for `model`: its predictor feeds measured
/// outputs through a noise model it never had (both kinds are fitted for simulation, output error).
std::string prediction_note(const models::AnyModel& model) {
  if (const auto* lm = std::get_if<models::LinearModel>(&model.model)) {
    char gain[64];  // A(q) = 1 + a1 q^-1 + ..., a_1..a_na stored
    std::snprintf(gain, sizeof gain, "%.3g", 1.0 + lm->tf.a.squaredNorm());
    return "J_pred is worse than J_sim because this output-error model has no noise model: its one-step predictor "
           "y(k) = -a1*y(k-1) - ... + B(q)u(k) reads the measured, noisy outputs, so its error is A(q) times the "
           "simulation error, and A(q) multiplies white noise's power by 1 + sum(a_i^2) = " +
           std::string(gain) + ". Judge it by J_sim; J_pred fits a model fitted for prediction (ARX, PEM).";
  }
  return "J_pred is worse than J_sim because the model was trained for simulation (output error): its one-step predictor "
         "feeds the measured, noisy outputs into lags trained on its own noise-free outputs. Judge it by J_sim; J_pred "
         "fits a model trained for prediction (PEM).";
}

}  // namespace

void check(const ValidateRequest& q) {
  if (q.u.size() != q.y.size()) {
    throw RequestError("record", "the drive has " + std::to_string(q.u.size()) + " samples, the response " +
                                     std::to_string(q.y.size()));
  }
  if (q.init < 0) throw RequestError("init", "must be ≥ 0, got " + std::to_string(q.init));
  if (q.init >= q.u.size()) {
    throw RequestError("init", std::to_string(q.init) + " is not shorter than the data (" + std::to_string(q.u.size()) +
                                   " samples)");
  }
}

nlohmann::json to_json(const ValidateRequest& q) {
  return {{"model", q.model_name}, {"init", q.init}, {"samples", q.u.size()}};
}

ValidateReport validate_model(const ValidateRequest& q, Progress& progress) {
  check(q);
  progress.report(0.0, "reading the model " + q.model_name);
  models::AnyModel model = [&] {
    try {
      return models::model_from_json(q.model);
    } catch (const std::exception& e) {
      throw RequestError("model", e.what());
    }
  }();
  progress.report(0.2, "free-run simulation");
  ValidateReport report;
  report.y_sim = model.simulate(q.u, q.y, q.init);
  progress.report(0.6, "one-step prediction");
  report.y_pred = model.predict(q.u, q.y);
  const Eigen::Index n = q.u.size() - q.init;
  const double j_sim = models::j_percent(report.y_sim, q.y, q.init);
  const double j_pred = models::j_percent(report.y_pred, q.y, q.init);
  const std::string note = j_pred > j_sim ? prediction_note(model) : "";
  report.summary = {{"J_sim_pct", j_sim},
                    {"J_pred_pct", j_pred},
                    {"J_pred_note", note.empty() ? nlohmann::json(nullptr) : nlohmann::json(note)},
                    {"rmse", std::sqrt((report.y_sim - q.y).tail(n).squaredNorm() / static_cast<double>(n))},
                    {"samples", n},
                    {"kind", model.kind()},
                    {"init", q.init},
                    {"model", q.model_name}};
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases
