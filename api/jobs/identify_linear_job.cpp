#include "api/jobs/identify_linear_job.h"

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
#include "models/kinds/model_file.h"
#include "models/linear/linear_model.h"
#include "models/linear/process_alone.h"
#include "usecases/identify_linear.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The request of filled-in params, without its records.
usecases::IdentifyLinearRequest linear_request(const json& params) {
  usecases::IdentifyLinearRequest q;
  q.method = params.at("method").get<std::string>();
  q.order = params.at("order").get<int>();
  q.delay = params.at("delay").get<int>();
  if (params.at("scan").is_array()) q.scan = params.at("scan").get<std::vector<int>>();
  q.init = params.at("init").get<long>();
  q.decimation = params.at("decimation").get<int>();
  q.max_iterations = params.at("max_iterations").get<int>();
  q.process = params.at("process").get<std::string>();
  return q;
}

// The record the process-alone model is judged on: the loopback l(k) against the sensor y(k − lag) (an empty part
// stays empty).
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

json identify_linear_params(const json& params, const JobEnvironment& env) {
  const usecases::IdentifyLinearRequest d;
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  r.text("method", d.method);
  r.integer("order", d.order, -kAnyInteger, kAnyInteger);
  r.integer("delay", d.delay, -kAnyInteger, kAnyInteger);
  const json* scan = r.member("scan");
  if (scan == nullptr || scan->is_null()) {
    r.set("scan", nullptr);
  } else {
    r.integers("scan", {}, 0, 16, -kAnyInteger, kAnyInteger);
  }
  r.integer("init", d.init, -kAnyInteger, kAnyInteger);
  r.integer("decimation", d.decimation, -kAnyInteger, kAnyInteger);
  r.integer("max_iterations", d.max_iterations, -kAnyInteger, kAnyInteger);
  r.text("process", d.process);
  json filled = r.finish();
  const usecases::IdentifyLinearRequest q = linear_request(filled);
  check_request([&] {
    usecases::check(q);
    usecases::check_scan(q.scan, validation > 0);
  });
  return filled;
}

json identify_linear_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  SourcedRecord data = acquire_record(params, env, progress, control);
  usecases::IdentifyLinearRequest q = linear_request(params);
  // The process alone (the thesis's fig. 3.6, §4): its input is the drive as the converters delivered it — the
  // drive prefiltered by the converters' response, which the loopback channel measured.
  const bool alone = q.process == "alone";
  if (alone) {
    if (data.record.l_est.size() == 0) {
      throw std::runtime_error("params.process: \"alone\" needs the drive as the converters delivered it, and " +
                               data.source + " has none (on a sound card: serve --loopback-channel)");
    }
    data.record.u_est = data.record.l_est;
    data.record.u_val = data.record.l_val;
  }
  put_record(q, data, env.fs);
  progress.span(kExcitationShare, 0.9);
  usecases::IdentifyLinearReport report;
  check_request([&] { report = usecases::identify_linear(q, progress); });

  progress.span(0.9, 1.0);
  progress.at(0.0, "storing the model");
  const int order = report.summary.at("order").get<int>();
  const std::string model_id = store_model(env, models::linear_model_to_json(report.model),
                                           q.method + " order " + std::to_string(order) + " (" + control.job_id() + ")",
                                           control);
  std::vector<HistoryPoint> history;
  for (const usecases::LinearIteration& i : report.history) history.push_back({i.iteration, i.j_est_pct, kNaN});
  json summary = report.summary;
  summary["data"] = data.source;
  summary["history_source"] = history.empty() ? "the final model" : "output-error iterations of the final fit (from rest)";
  if (history.empty()) {
    history.push_back({0, summary.at("J_est_pct").get<double>(),
                       summary.at("J_val_pct").is_number() ? summary.at("J_val_pct").get<double>() : kNaN});
  }
  const models::AnyModel any{report.model};
  json plots = model_plots(any, alone ? lagged(data.record) : data.record, env.fs);
  plots["history"] = history_plot(history);
  progress.at(1.0, "done");
  return identified_model_result(model_id, summary, report.warnings, plots);
}

}  // namespace

JobKind identify_linear_job() { return {"identify-linear", identify_linear_params, identify_linear_work, "linear"}; }

}  // namespace panelbass::api
