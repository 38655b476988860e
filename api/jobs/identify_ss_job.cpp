#include "api/jobs/identify_ss_job.h"

#include <limits>
#include <string>

#include "api/jobs/model_judgement.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/state_space_nn/ss_model.h"
#include "usecases/identify_ss.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params, without its records and models.
usecases::IdentifySsRequest ss_request(const json& params) {
  usecases::IdentifySsRequest q;
  q.nx = params.at("nx").get<int>();
  q.nk = params.at("nk").get<int>();
  q.hidden = params.at("hidden").get<int>();
  q.poly_degree = params.at("poly_degree").get<int>();
  q.poly_states = params.at("poly_states").get<int>();
  q.poly_states_only = params.at("poly_states_only").get<bool>();
  q.activation = params.at("activation").get<std::string>();
  q.hidden_states_only = params.at("hidden_states_only").get<bool>();
  q.wiener_hammerstein = params.at("wiener_hammerstein").get<bool>();
  q.wh_iterations = params.at("wh_iterations").get<int>();
  q.wh_candidates = params.at("wh_candidates").get<int>();
  q.lags = params.at("lags").get<int>();
  q.encoder_hidden = params.at("encoder_hidden").get<int>();
  q.window = params.at("window").get<long>();
  q.batch = params.at("batch").get<long>();
  q.epochs = params.at("epochs").get<int>();
  q.max_seconds = params.at("max_seconds").get<double>();
  q.patience = params.at("patience").get<int>();
  q.learning_rate = params.at("learning_rate").get<double>();
  q.final_learning_rate = params.at("final_learning_rate").get<double>();
  q.polish_iterations = params.at("polish_iterations").get<int>();
  q.polish_window = params.at("polish_window").get<long>();
  q.initial_state = params.at("initial_state").get<std::string>();
  q.init = params.at("init").get<long>();
  q.seed = params.at("seed").get<std::uint64_t>();
  return q;
}

json identify_ss_params(const json& params, const JobEnvironment& env) {
  const usecases::IdentifySsRequest d;
  ParamReader r(params, "params");
  std::string validation_path;
  record_source(r, env, validation_path);
  require_stored_model(r, "linear", false, {"linear"}, env);
  require_stored_model(r, "start_from", false, {"ss"}, env);
  r.integer("nx", d.nx, -kAnyInteger, kAnyInteger);
  r.integer("nk", d.nk, -kAnyInteger, kAnyInteger);
  r.integer("hidden", d.hidden, -kAnyInteger, kAnyInteger);
  r.integer("poly_degree", d.poly_degree, -kAnyInteger, kAnyInteger);
  r.integer("poly_states", d.poly_states, -kAnyInteger, kAnyInteger);
  r.boolean("poly_states_only", d.poly_states_only);
  r.text("activation", d.activation);
  r.boolean("hidden_states_only", d.hidden_states_only);
  r.boolean("wiener_hammerstein", d.wiener_hammerstein);
  r.integer("wh_iterations", d.wh_iterations, -kAnyInteger, kAnyInteger);
  r.integer("wh_candidates", d.wh_candidates, -kAnyInteger, kAnyInteger);
  r.integer("lags", d.lags, -kAnyInteger, kAnyInteger);
  r.integer("encoder_hidden", d.encoder_hidden, -kAnyInteger, kAnyInteger);
  r.integer("window", d.window, -kAnyInteger, kAnyInteger);
  r.integer("batch", d.batch, -kAnyInteger, kAnyInteger);
  r.integer("epochs", d.epochs, -kAnyInteger, kAnyInteger);
  r.number("max_seconds", d.max_seconds, kAnyFinite);
  r.integer("patience", d.patience, -kAnyInteger, kAnyInteger);
  r.number("learning_rate", d.learning_rate, kAnyFinite);
  r.number("final_learning_rate", d.final_learning_rate, kAnyFinite);
  r.integer("polish_iterations", d.polish_iterations, -kAnyInteger, kAnyInteger);
  r.integer("polish_window", d.polish_window, -kAnyInteger, kAnyInteger);
  r.text("initial_state", d.initial_state);
  r.integer("init", d.init, -kAnyInteger, kAnyInteger);
  r.integer("seed", static_cast<long long>(d.seed), 0, kMaxSeed);
  json filled = r.finish();
  check_request([&] { usecases::check(ss_request(filled)); });
  return filled;
}

json identify_ss_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  usecases::IdentifySsRequest q = ss_request(params);
  put_record(q, data, env.fs);
  if (params.contains("linear") && params.at("linear").is_string()) {
    q.linear_name = params.at("linear").get<std::string>();
    q.linear = models::linear_model_from_json(stored_model_file(env, q.linear_name));
  }
  if (params.contains("start_from") && params.at("start_from").is_string()) {
    q.start_from_name = params.at("start_from").get<std::string>();
    q.start_from = models::ss_model_from_json(stored_model_file(env, q.start_from_name));
  }
  progress.span(kExcitationShare, 0.95);
  usecases::IdentifySsReport report;
  check_request([&] { report = usecases::identify_ss(q, progress); });
  const std::string model_id = store_model(env, models::ss_model_to_json(report.model),
                                           "ss on " + data.source + " (" + control.job_id() + ")", control);
  const JudgedPart part = judged_part(data.record);
  const Eigen::VectorXd y_sim = report.model.simulate(part.u, part.y, q.init);
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  json result = identified_model_result(model_id, report.summary, report.warnings, part, y_sim, env.fs);
  result["history"] = report.history;
  return result;
}

}  // namespace

JobKind identify_ss_job() { return {"identify-ss", identify_ss_params, identify_ss_work, "ss"}; }

}  // namespace panelbass::api
