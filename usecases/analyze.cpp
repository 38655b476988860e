#include "usecases/analyze.h"

#include <cmath>
#include <utility>
#include <variant>

#include "models/io/number_text.h"
#include "usecases/request_checks.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

void check(const AnalyzeRequest& q) {
  within("init", q.init, 0, 100000000);
  within("lags", q.lags, 1, 10000);
  if (q.segment != 0) within("segment", q.segment, 16, 1L << 24);
  within("refine_iterations", q.refine_iterations, 0, 10000);
  if (!q.gain_range.empty() &&
      (q.gain_range.size() != 2 || !std::isfinite(q.gain_range[0]) || !std::isfinite(q.gain_range[1]) ||
       !(q.gain_range[1] > q.gain_range[0]))) {
    throw RequestError("gain_range", "expected two finite gains, the first below the second");
  }
  if (q.frequencies.empty()) throw RequestError("frequencies", "name at least one frequency");
  for (const double f : q.frequencies) {
    if (!(f > 0.0 && std::isfinite(f))) throw RequestError("frequencies", "each must be > 0 Hz, got " + models::number_text(f));
  }
  if (q.amplitudes.empty()) throw RequestError("amplitudes", "name at least one amplitude");
  for (const double a : q.amplitudes) {
    if (!(a > 0.0 && a <= 1.0)) throw RequestError("amplitudes", "each must be within (0, 1], got " + models::number_text(a));
  }
  within("measure", q.measure, 100, 10000000);
  if (q.u.size() != q.y.size()) {
    throw RequestError("record", "the drive has " + std::to_string(q.u.size()) + " samples, the response " +
                                     std::to_string(q.y.size()));
  }
  if (q.u.size() > 0 && q.init >= q.u.size()) {
    throw RequestError("init", std::to_string(q.init) + " is not shorter than the data (" + std::to_string(q.u.size()) +
                                   " samples)");
  }
}

nlohmann::json to_json(const AnalyzeRequest& q) {
  return {{"model", q.model_name},
          {"record", q.data_name},
          {"init", q.init},
          {"lags", q.lags},
          {"segment", q.segment},
          {"refine_iterations", q.refine_iterations},
          {"gain_range", q.gain_range.empty() ? nlohmann::json(nullptr) : nlohmann::json(q.gain_range)},
          {"plant", q.plant_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(q.plant_name)},
          {"frequencies", q.frequencies},
          {"amplitudes", q.amplitudes},
          {"measure", q.measure}};
}

AnalyzeReport analyze(const AnalyzeRequest& q, Progress& progress) {
  check(q);
  if (q.u.size() == 0) throw RequestError("record", "no samples");
  progress.report(0.0, "reading the model " + q.model_name);
  const models::AnyModel model = [&] {
    try {
      return models::model_from_json(q.model);
    } catch (const std::exception& e) {
      throw RequestError("model", e.what());
    }
  }();
  models::AnalysisSpec spec;
  spec.init = q.init;
  spec.max_lag = q.lags;
  spec.segment = static_cast<std::size_t>(q.segment);
  spec.refine_iterations = q.refine_iterations;
  if (!q.gain_range.empty()) {
    spec.gain_min = q.gain_range[0];
    spec.gain_max = q.gain_range[1];
  }
  if (q.plant) {
    spec.plant = q.plant;
    spec.distortion.frequencies = q.frequencies;
    spec.distortion.amplitudes = q.amplitudes;
    spec.distortion.measure = static_cast<std::size_t>(q.measure);
  }
  spec.progress = [&](const std::string& stage, double f) { progress.report(f, "analysis: " + stage); };
  std::optional<models::TrainingHistory> history = q.history;
  if (!history) {
    const nlohmann::json meta = std::visit([](const auto& m) { return m.meta; }, model.model);
    history = models::training_history_from_json(nlohmann::json{{"meta", meta}}, q.model_name);
  }
  AnalyzeReport report;
  report.analysis = models::analyze_model(model, q.u, q.y, spec, std::move(history));
  report.summary = models::analysis_to_json(report.analysis);
  report.summary["model"] = q.model_name;
  report.summary["data"] = q.data_name;
  report.summary["plant"] = q.plant ? nlohmann::json(q.plant_name) : nlohmann::json(nullptr);
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases
