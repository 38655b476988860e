#include "api/jobs/identify_narx_job.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/hidden_layers.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/kinds/model_file.h"
#include "models/narx/narx_model.h"
#include "usecases/identify_narx.h"
#include "usecases/narx_restarts.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params, without its records and models.
usecases::IdentifyNarxRequest narx_request(const json& params) {
  usecases::IdentifyNarxRequest q;
  q.na = params.at("na").get<int>();
  q.nb = params.at("nb").get<int>();
  q.nk = params.at("nk").get<int>();
  q.hidden = params.at("hidden").get<std::vector<int>>();
  q.modes = params.at("modes").get<std::vector<std::string>>();
  q.optimizer = params.at("optimizer").get<std::string>();
  q.max_iterations = params.at("max_iterations").get<int>();
  q.pem_max_iterations = params.at("pem_max_iterations").get<int>();
  q.pem_min_progress = params.at("pem_min_progress").get<double>();
  q.step = params.at("step").get<double>();
  q.batch = params.at("batch").get<long>();
  q.skip = params.at("skip").get<long>();
  q.patience = params.at("patience").get<int>();
  if (params.at("weight_decay").is_number()) q.weight_decay = params.at("weight_decay").get<double>();
  if (params.at("evidence_decay").is_string()) q.evidence_decay = params.at("evidence_decay").get<std::string>();
  q.init = params.at("init").get<long>();
  q.seed = params.at("seed").get<std::uint64_t>();
  q.restarts = params.at("restarts").get<int>();
  q.grow = params.at("grow").get<int>();
  q.prune = params.at("prune").get<bool>();
  q.friction_units = params.at("friction_units").get<std::vector<double>>();
  q.friction_lags = params.at("friction_lags").get<int>();
  const json& ms = params.at("multiple_shooting");
  q.multiple_shooting.window = ms.at("window").get<Eigen::Index>();
  q.multiple_shooting.penalty = ms.at("penalty").get<double>();
  q.multiple_shooting.penalty_growth = ms.at("penalty_growth").get<double>();
  q.multiple_shooting.penalty_max = ms.at("penalty_max").get<double>();
  return q;
}

json identify_narx_params(const json& params, const JobEnvironment& env) {
  const usecases::IdentifyNarxRequest d;
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  require_stored_model(r, "start_from", false, {"narx"}, env);
  const json* start_from_id = r.member("start_from");
  const bool start_from = start_from_id != nullptr && start_from_id->is_string();
  if (!start_from) r.set("start_from", nullptr);
  r.integer("na", d.na, -kAnyInteger, kAnyInteger);
  r.integer("nb", d.nb, -kAnyInteger, kAnyInteger);
  r.integer("nk", d.nk, -kAnyInteger, kAnyInteger);
  r.integers("hidden", {d.hidden.begin(), d.hidden.end()}, 0, 64, -kAnyInteger, kAnyInteger);
  r.texts("modes", d.modes);
  r.text("optimizer", d.optimizer);
  r.integer("max_iterations", d.max_iterations, -kAnyInteger, kAnyInteger);
  r.integer("pem_max_iterations", d.pem_max_iterations, -kAnyInteger, kAnyInteger);
  r.number("pem_min_progress", d.pem_min_progress, kAnyFinite);
  r.number("step", d.step, kAnyFinite);
  r.integer("batch", d.batch, -kAnyInteger, kAnyInteger);
  r.integer("skip", d.skip, -kAnyInteger, kAnyInteger);
  r.integer("patience", d.patience, -kAnyInteger, kAnyInteger);
  if (const json* wd = r.member("weight_decay"); wd == nullptr || wd->is_null()) {
    r.set("weight_decay", nullptr);  // the optimizer's default (usecases::IdentifyNarxRequest::weight_decay)
  } else {
    r.number("weight_decay", 0.0, kAnyFinite);
  }
  if (const json* ed = r.member("evidence_decay"); ed == nullptr || ed->is_null()) {
    r.set("evidence_decay", nullptr);  // the optimizer's default (usecases::IdentifyNarxRequest::evidence_decay)
  } else {
    r.text("evidence_decay", "");
  }
  r.integer("init", d.init, -kAnyInteger, kAnyInteger);
  r.integer("seed", static_cast<long long>(d.seed), 0, kMaxSeed);
  r.integer("restarts", d.restarts, -kAnyInteger, kAnyInteger);
  r.integer("grow", d.grow, -kAnyInteger, kAnyInteger);
  r.boolean("prune", d.prune);
  r.numbers("friction_units", d.friction_units, 0, 64, kAnyFinite);
  r.integer("friction_lags", d.friction_lags, -kAnyInteger, kAnyInteger);
  {
    ParamReader ms(r.member("multiple_shooting") ? *r.member("multiple_shooting") : json(nullptr),
                   r.path_of("multiple_shooting"));
    ms.integer("window", d.multiple_shooting.window, -kAnyInteger, kAnyInteger);
    ms.number("penalty", d.multiple_shooting.penalty, kAnyFinite);
    ms.number("penalty_growth", d.multiple_shooting.penalty_growth, kAnyFinite);
    ms.number("penalty_max", d.multiple_shooting.penalty_max, kAnyFinite);
    r.set("multiple_shooting", ms.finish());
  }
  // The control excitation's harmonic weights in the loss (identify narx --weight-col w).
  if (r.boolean("weighted", false)) {
    const json* excite = r.member("excite");
    const json* record = r.member("record");
    const bool has_weights = record != nullptr ? record_has_weights(env, record->get<std::string>())
                                               : excite != nullptr && excite->value("signal", "") == "control";
    if (!has_weights) {
      std::string which = "this job's excitation is not one";
      if (record != nullptr) {
        const std::string id = record->get<std::string>();
        which = is_record_id(id) ? "uploaded record " + id + " has none" : "job " + id + "'s record has none";
      }
      refuse(r.path_of("weighted"), "the weights come with a control excitation (excite.signal \"control\"), and " + which);
    }
  }
  json filled = r.finish();
  usecases::IdentifyNarxRequest q = narx_request(filled);
  check_request([&] {
    // start_from's model is read when the job runs: a placeholder of it here, for the checks that only need to know
    // there is one.
    if (start_from) q.start_from = models::NarxModel{};
    usecases::check(q);
    usecases::check_restarts(q.restarts, !start_from && q.grow == 0 && q.friction_units.empty(), validation > 0);
  });
  return filled;
}

json identify_narx_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;
  usecases::IdentifyNarxRequest q = narx_request(params);
  put_record(q, data, env.fs);
  if (params.value("weighted", false)) {
    if (r.w_est.size() == 0) throw std::invalid_argument("params.weighted: the record has no harmonic weights");
    q.w_est = r.w_est;
    q.w_val = r.w_val;
  }
  if (params.contains("start_from") && params.at("start_from").is_string()) {
    q.start_from_name = params.at("start_from").get<std::string>();
    q.start_from = models::narx_model_from_json(stored_model_file(env, q.start_from_name));
  }
  progress.span(kExcitationShare, 0.85);
  usecases::IdentifyNarxReport report;
  check_request([&] { report = usecases::identify_narx(q, progress); });

  progress.span(0.85, 1.0);
  progress.at(0.2, "storing the model");
  const models::NarxStructure& s = report.model.structure;
  const std::string name = "narx " + std::to_string(s.na) + "/" + std::to_string(s.nb) + "/" + std::to_string(s.nk) + " " +
                           hidden_text(s.hidden) + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::narx_model_to_json(report.model), name, control);

  std::vector<HistoryPoint> history;
  for (const models::TrainingRecord& rec : report.history) history.push_back({rec.iteration, rec.j_est_pct, rec.j_val_pct});
  const models::AnyModel any{report.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.span(0.9, 1.0);
  const json harmonics = harmonics_if_known(env, any, r, progress);
  if (!harmonics.is_null()) plots["harmonics"] = harmonics;
  progress.at(1.0, "done");
  json summary = report.summary;
  summary["data"] = data.source;
  // The job's summary has always named these beside "structure" (ROUTES.md).
  for (const char* key : {"restarts", "friction_units"}) {
    if (summary.at("structure").contains(key)) summary[key] = summary.at("structure").at(key);
  }
  return identified_model_result(model_id, summary, report.warnings, plots);
}

}  // namespace

JobKind identify_narx_job() { return {"identify-narx", identify_narx_params, identify_narx_work, "narx"}; }

}  // namespace panelbass::api
