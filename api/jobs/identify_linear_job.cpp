#include "api/jobs/identify_linear_job.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/io/json_fields.h"
#include "models/io/roots_json.h"
#include "models/kinds/model_file.h"
#include "models/linear/data_survey.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/linear_identification.h"
#include "models/linear/linear_model.h"
#include "models/linear/process_alone.h"
#include "models/preprocess/scaling.h"
#include "models/validation/performance.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// FIR taps go further than the orders of the other methods.
constexpr long long kMaxFirTaps = 2000;

json identify_linear_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  const std::string method = r.choice("method", "oe", {"fir", "arx", "oe", "zhu", "backx"});
  r.integer("order", 8, 1, method == "fir" ? kMaxFirTaps : kMaxOrder);
  r.integer("delay", -1, -1, 1000);
  const json* scan = r.member("scan");
  if (scan == nullptr || scan->is_null()) {
    r.set("scan", nullptr);
  } else {
    const std::vector<long long> range = r.integers("scan", {}, 2, 2, 1, kMaxOrder);
    if (range[0] > range[1]) refuse(r.path_of("scan"), "expected [from, to] with from <= to, got " + shown(*scan));
    if (validation == 0) refuse(r.path_of("scan"), "an order scan needs validation data (" + validation_path + " has none)");
  }
  r.integer("max_iterations", 100, 1, kMaxIterations);
  r.choice("process", "with_converters", {"with_converters", "alone"});
  return r.finish();
}

// The record with the converters' output as its drive (ExcitationRecord::l_est/l_val); throws naming what is
// missing when the record has none.
ExcitationRecord process_record(const SourcedRecord& data) {
  ExcitationRecord r = data.record;
  if (r.l_est.size() == 0) {
    throw std::runtime_error("params.process: \"alone\" needs the drive as the converters delivered it, and " +
                             data.source + " has none (on a sound card: serve --loopback-channel)");
  }
  r.u_est = r.l_est;
  r.u_val = r.l_val;
  return r;
}

// The record from the loopback l(k) to the sensor y(k − models::kProcessAloneLagSamples) (an empty part stays
// empty).
ExcitationRecord lagged(const ExcitationRecord& r) {
  ExcitationRecord out = r;
  const models::LoopbackPair est = models::process_alone_pair(r.u_est, r.y_est);
  const models::LoopbackPair val = models::process_alone_pair(r.u_val, r.y_val);
  out.u_est = est.l;
  out.y_est = est.y;
  out.u_val = val.l;
  out.y_val = val.y;
  return out;
}

// What to try when a linear fit is no better than an output of zero.
std::string linear_advice(const models::LinearIdentification& id) {
  return "Check the delay (delay = " + std::to_string(id.model.tf.nk) + ", " + id.nk_source +
         "); then try another method (oe, zhu, backx), an order scan, or more max_iterations.";
}

json identify_linear_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  // The process alone (the thesis's fig. 3.6, §4): its input is the drive as the converters delivered it —
  // the drive prefiltered by the converters' response, which the loopback channel measured.
  const bool alone = params.at("process").get<std::string>() == "alone";
  const ExcitationRecord r = alone ? lagged(process_record(data)) : data.record;

  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(params.at("method").get<std::string>());
  spec.order = params.at("order").get<int>();
  spec.delay = params.at("delay").get<int>();
  const bool scanning = params.at("scan").is_array();
  if (scanning) {
    spec.scan_from = params.at("scan")[0].get<int>();
    spec.scan_to = params.at("scan")[1].get<int>();
  }
  spec.init = kInit;
  spec.fs = env.fs;
  spec.oe.max_iterations = params.at("max_iterations").get<int>();

  // J per output-error iteration of the final fit: the OE loss (mean squared simulation error, scaled
  // units) over the mean square of the scaled output, the [2A] ratio from rest.
  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  const double output_power = scaling.scale_y(r.y_est).squaredNorm() / static_cast<double>(r.y_est.size());
  const int fits = scanning ? spec.scan_to - spec.scan_from + 2 : 1;
  double base = 0.0;
  std::vector<HistoryPoint> history;
  const std::string method = params.at("method").get<std::string>();
  progress.span(kExcitationShare, 0.9);
  spec.progress = [&](const std::string& stage, double f) {
    if (f == 0.0 || stage == "scan") history.clear();  // a fit starts; the last one's iterations are kept
    base = models::identification_fraction(spec, stage, stage == "fit" ? 0.0 : f);  // a fit's iterations add to it
    progress.at(base, method + ": " + stage);
  };
  spec.oe.progress = [&](int iteration, double loss) {
    history.push_back({iteration, models::j_ratio_percent(loss, output_power), kNaN});
    progress.at(base + static_cast<double>(iteration) / spec.oe.max_iterations / fits,
                method + " iteration " + std::to_string(iteration));
  };
  models::LinearIdentification id =
      alone ? models::identify_process_alone({r.u_est, r.y_est}, {r.u_val, r.y_val}, spec)
            : models::identify_linear(r.u_est, r.y_est, r.u_val, r.y_val, spec);

  progress.span(0.9, 1.0);
  progress.at(0.0, "storing the model");
  id.model.meta = {{"data", data.source + " (estimation)"},
                   {"val", r.u_val.size() ? json(data.source + " (validation)") : json("")},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", models::number_or_null(id.j_val_pct)},
                   {"process", alone ? "alone: the input is the drive as the converters delivered it (loopback), the "
                                       "converters left out; fitted from l(k) to y(k - " + std::to_string(models::kProcessAloneLagSamples) +
                                       ") (the model carries that many samples more delay than the process) and weighted toward the low end"
                                     : "with_converters: the input is the drive, the converters included"}};
  const int order = id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb();
  const std::string model_id = store_model(env, models::linear_model_to_json(id.model),
                                           method + " order " + std::to_string(order) + " (" + control.job_id() + ")", control);

  const std::string history_source = history.empty() ? "the final model" : "output-error iterations of the final fit (from rest)";
  if (history.empty()) history.push_back({0, id.j_est_pct, id.j_val_pct});
  json summary = {{"method", method},
                  {"order", order},
                  {"na", id.model.tf.na()},
                  {"nb", id.model.tf.nb()},
                  {"delay", id.model.tf.nk},
                  {"nk_source", id.nk_source},
                  {"J_pred_est_pct", id.j_pred_est_pct},
                  {"poles", models::roots_json(id.model.tf.poles())},
                  {"zeros", models::roots_json(id.model.tf.zeros())},
                  {"survey", models::data_survey_to_json(id.survey)},
                  {"data", data.source},
                  {"process", params.at("process")},
                  {"history_source", history_source}};
  if (!id.scan.empty()) {
    json scan = json::array();
    for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
    summary["scan"] = scan;
    summary["order_rule"] = id.order_rule;
    summary["scan_skipped"] = id.scan_skipped;
  }
  const models::AnyModel any{id.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.at(1.0, "done");
  const bool validated = r.u_val.size() > 0;
  return {{"model_id", model_id},
          {"j_est_pct", id.j_est_pct},
          {"j_val_pct", models::number_or_null(id.j_val_pct)},
          {"summary", summary},
          {"plots", plots},
          {"warnings", models::fit_warnings(validated ? id.j_val_pct : id.j_est_pct, validated ? "J_val" : "J_est",
                                            kNaN, linear_advice(id))}};
}

}  // namespace

JobKind identify_linear_job() { return {"identify-linear", identify_linear_params, identify_linear_work, "linear"}; }

}  // namespace panelbass::api
