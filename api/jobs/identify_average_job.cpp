#include "api/jobs/identify_average_job.h"

#include <limits>
#include <string>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "api/model_store.h"
#include "models/state_space_nn/ss_model.h"
#include "usecases/identify_average.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The most models one average takes (its states are theirs side by side).
constexpr std::size_t kMaxMembers = 64;

// True when the params name where a validation record comes from.
bool has_record(const json& params) {
  return params.is_object() && (params.contains("record") || params.contains("excite") || params.contains("val_fraction"));
}

// The request of filled-in params: the stored models read, without the validation record.
usecases::IdentifyAverageRequest average_request(const json& params, const JobEnvironment& env) {
  usecases::IdentifyAverageRequest q;
  for (const json& id : params.at("models")) {
    q.model_names.push_back(id.get<std::string>());
    q.models.push_back(models::ss_model_from_json(stored_model_file(env, q.model_names.back())));
  }
  q.init = params.at("init").get<long>();
  return q;
}

json identify_average_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  const std::string where = r.path_of("models");
  const json* ids = r.member("models");
  if (ids == nullptr || !ids->is_array() || ids->empty() || ids->size() > kMaxMembers) {
    refuse(where, "expected an array of 1.." + std::to_string(kMaxMembers) + " stored ss models' ids, got " +
                      (ids == nullptr ? std::string("none") : shown(*ids)));
  }
  for (std::size_t i = 0; i < ids->size(); ++i) {
    const json& id = (*ids)[i];
    const std::string at = where + "[" + std::to_string(i) + "]";
    if (!id.is_string() || !is_valid_id(id.get<std::string>())) refuse(at, "expected a model id, got " + shown(id));
    require_stored_id(id.get<std::string>(), at, {"ss"}, env);
  }
  r.set("models", *ids);
  if (has_record(params)) {
    std::string validation_path;
    record_source(r, env, validation_path);
  }
  r.integer("init", usecases::IdentifyAverageRequest{}.init, -kAnyInteger, kAnyInteger);
  json filled = r.finish();
  // The models beside each other before anything is queued (the validation record's length is checked when it is).
  check_request([&] { usecases::check(average_request(filled, env)); });
  return filled;
}

json identify_average_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  usecases::IdentifyAverageRequest q = average_request(params, env);
  std::string source = "no validation record";
  if (has_record(params)) {
    const SourcedRecord data = acquire_record(params, env, progress, control);
    const JudgedPart part = judged_part(data.record);
    q.u_val = part.u;
    q.y_val = part.y;
    source = data.source + (part.validation ? " (validation)" : " (estimation)");
    q.val_name = source;
  }
  progress.span(kExcitationShare, 0.95);
  usecases::IdentifyAverageReport report;
  check_request([&] { report = usecases::identify_average(q, progress); });
  const std::string model_id = store_model(env, models::ss_model_to_json(report.model),
                                           "average of " + std::to_string(report.summary.at("members").size()) +
                                               " ss models (" + control.job_id() + ")",
                                           control);
  json plots = json::object();
  if (q.u_val.size() > 0) {
    const Eigen::VectorXd y_sim = report.model.simulate(q.u_val, q.y_val, q.init);
    plots = {{"fit", fit_plot(q.y_val, y_sim, env.fs)}, {"spectrum", spectrum_plot(q.u_val, q.y_val, y_sim, env.fs)}};
  }
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return {{"model_id", model_id},
          {"j_est_pct", nullptr},
          {"j_val_pct", report.summary.at("J_val_pct")},
          {"summary", report.summary},
          {"warnings", report.warnings},
          {"plots", plots}};
}

}  // namespace

JobKind identify_average_job() { return {"identify-average", identify_average_params, identify_average_work, "ss"}; }

}  // namespace panelbass::api
