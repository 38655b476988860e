#include "api/jobs/identify_narx_job.h"

#include <algorithm>
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
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/linear/data_survey.h"
#include "models/linear/fit_warnings.h"
#include "models/narx/friction_seed.h"
#include "models/narx/narx_model.h"
#include "models/narx/narx_training.h"
#include "models/preprocess/scaling.h"
#include "usecases/narx_restarts.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

json identify_narx_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  r.integer("na", 2, 0, kMaxOrder);
  r.integer("nb", 3, 0, kMaxOrder);
  r.integer("nk", -1, -1, 1000);
  const std::vector<long long> hidden = hidden_layers(r, {8});
  r.choices("modes", {"pem", "oem-d"}, {"pem", "oem-s", "oem-d", "oem-n"});
  r.integer("max_iterations", 30, 0, kMaxIterations);
  r.integer("pem_max_iterations", models::TrainingOptions{}.pem_max_iterations, -1, kMaxIterations);
  r.number("pem_min_progress", models::kDefaultPemMinProgress, {0.0, 1.0, false, true});
  r.number("weight_decay", models::kDefaultLmWeightDecay, {0.0, 1e6, false, false});
  r.integer("seed", 1, 0, kMaxSeed);
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
  // Hidden nodes seeded as Coulomb friction (models::seed_friction_units): one per gain and lag.
  const std::vector<double> gains = r.numbers("friction_units", {}, 0, 16, {0.0, 1000.0, true, false});
  const long long lags = r.integer("friction_lags", 1, 1, 20);
  if (static_cast<long long>(gains.size()) * lags > hidden[0]) {
    refuse(r.path_of("friction_units"), std::to_string(gains.size()) + " gains x " + std::to_string(lags) +
                                            " lags need as many first-layer nodes, hidden[0] is " + std::to_string(hidden[0]));
  }
  // Trainings from seeds seed … seed + restarts − 1 (usecases/narx_restarts.h), refused as the CLI refuses them.
  const long long restarts = r.integer("restarts", usecases::NarxRestartsRequest{}.restarts, -kAnyInteger, kAnyInteger);
  check_request([&] { usecases::check_restarts(static_cast<int>(restarts), gains.empty(), validation > 0); });
  return r.finish();
}

json identify_narx_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;

  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  int nk = params.at("nk").get<int>();
  std::string nk_source = "given";
  if (nk < 0) {
    const models::DataSurvey survey = models::survey_data(r.u_est, r.y_est);
    nk = survey.delay;
    nk_source = models::delay_finding(survey);
  }
  const models::NarxStructure structure{params.at("na").get<int>(), params.at("nb").get<int>(), nk,
                                        hidden_widths(params.at("hidden"))};
  usecases::NarxRestartsRequest q;
  q.seed = params.at("seed").get<std::uint64_t>();
  q.restarts = params.at("restarts").get<int>();
  q.start = models::NarxModel::with_structure(structure, scaling, env.fs);
  q.start.net.initialize(1.0, q.seed);
  q.u_est = r.u_est;
  q.y_est = r.y_est;
  q.u_val = r.u_val;
  q.y_val = r.y_val;
  const Eigen::VectorXd us = scaling.scale_u(r.u_est), ys = scaling.scale_y(r.y_est);
  const Eigen::VectorXd uv = r.u_val.size() ? scaling.scale_u(r.u_val) : Eigen::VectorXd();
  json friction = nullptr;
  if (const auto gains = params.value("friction_units", std::vector<double>{}); !gains.empty()) {
    friction = models::friction_seed_report(
        models::seed_friction_units(q.start, us, ys, gains, params.value("friction_lags", 1)));
    q.fresh_start = false;
  }

  models::TrainingOptions options;
  options.modes.clear();
  std::string train;
  for (const json& m : params.at("modes")) {
    options.modes.push_back(models::parse_training_mode(m.get<std::string>()));
    train += (train.empty() ? "" : ",") + m.get<std::string>();
  }
  options.optimizer = models::Optimizer::lm;
  options.max_iterations = params.at("max_iterations").get<int>();
  options.pem_max_iterations = params.at("pem_max_iterations").get<int>();
  options.pem_min_progress = params.at("pem_min_progress").get<double>();
  options.weight_decay = params.at("weight_decay").get<double>();
  const bool weighted = params.value("weighted", false);
  if (weighted) {
    if (r.w_est.size() == 0) throw std::invalid_argument("params.weighted: the record has no harmonic weights");
    options.weights = r.w_est;
    options.validation_weights = r.w_val;
  }
  // Training selects and stops on the J the job reports (simulation_j): the first init_samples() measured
  // outputs set the state, then free run.
  options.init = init_samples(std::min(us.size(), uv.size() ? uv.size() : us.size()));
  q.options = options;
  progress.span(kExcitationShare, 0.85);
  usecases::NarxRestartsReport restarted;
  check_request([&] { restarted = usecases::train_narx_restarts(q, progress); });
  models::TrainingResult& trained = restarted.result;

  progress.span(0.85, 1.0);
  progress.at(0.0, "judging the model");
  const models::AnyModel judged{trained.model};
  const double j_est = simulation_j(judged, r.u_est, r.y_est);
  const double j_val = simulation_j(judged, r.u_val, r.y_val);
  json meta_history = json::array();
  std::vector<HistoryPoint> history;
  for (std::size_t k = 0; k < trained.history.size(); ++k) {
    const models::TrainingRecord& rec = trained.history[k];
    meta_history.push_back({{"iter", rec.iteration}, {"mode", models::to_string(rec.mode)},
                            {"J_est_pct", models::number_or_null(rec.j_est_pct)}, {"J_val_pct", models::number_or_null(rec.j_val_pct)}});
    history.push_back({rec.iteration, rec.j_est_pct, rec.j_val_pct});
  }
  trained.model.meta = {{"data", data.source + " (estimation)"},
                        {"val", r.u_val.size() ? json(data.source + " (validation)") : json("")},
                        {"train", train},
                        {"optimizer", "lm"},
                        {"J_est_pct", j_est},
                        {"J_val_pct", models::number_or_null(j_val)},
                        {"seed", restarted.chosen_seed},
                        {"weighted", weighted},
                        {"history", meta_history}};
  if (!friction.is_null()) trained.model.meta["friction_units"] = friction;
  progress.at(0.1, "a linear model of the same order on the same record, for comparison");
  const double j_judged = r.u_val.size() ? j_val : j_est;
  const double j_linear = models::linear_reference_j_pct(r.u_est, r.y_est, r.u_val, r.y_val,
                                                         std::max(structure.na, structure.nb), structure.nk,
                                                         init_samples(r.u_val.size() ? r.u_val.size() : r.u_est.size()));
  const std::vector<std::string> warnings = models::fit_warnings(
      j_judged, r.u_val.size() ? "J_val" : "J_est", j_linear,
      "Check the delay (nk = " + std::to_string(structure.nk) + ", " + nk_source +
          "); then try more iterations (max_iterations), another seed, or other lags (na, nb).");
  progress.at(0.2, "storing the model");
  const std::string name = "narx " + std::to_string(structure.na) + "/" + std::to_string(structure.nb) + "/" +
                           std::to_string(structure.nk) + " " + hidden_text(structure.hidden) + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::narx_model_to_json(trained.model), name, control);

  const models::AnyModel any{trained.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.span(0.9, 1.0);
  const json harmonics = harmonics_if_known(env, any, r, progress);
  if (!harmonics.is_null()) plots["harmonics"] = harmonics;
  progress.at(1.0, "done");
  json result = {{"model_id", model_id},
                 {"j_est_pct", j_est},
                 {"j_val_pct", models::number_or_null(j_val)},
                 {"summary",
                  {{"na", structure.na},
                   {"nb", structure.nb},
                   {"nk", structure.nk},
                   {"nk_source", nk_source},
                   {"linear_reference_j_pct", models::number_or_null(j_linear)},
                   {"hidden", structure.hidden},
                   {"modes", params.at("modes")},
                   {"params", trained.model.net.parameter_count()},
                   {"iterations", trained.iterations},
                   {"seconds", trained.seconds},
                   {"weighted", weighted},
                   {"data", data.source}}},
                 {"plots", plots}};
  if (!friction.is_null()) result["summary"]["friction_units"] = friction;
  if (!restarted.restarts.is_null()) result["summary"]["restarts"] = restarted.restarts;
  result["warnings"] = warnings;
  return result;
}

}  // namespace

JobKind identify_narx_job() { return {"identify-narx", identify_narx_params, identify_narx_work, "narx"}; }

}  // namespace panelbass::api
