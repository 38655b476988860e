#include "usecases/identify_narx.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "dsp/sample_rate.h"
#include "models/io/json_fields.h"
#include "models/linear/data_survey.h"
#include "models/linear/fit_warnings.h"
#include "models/narx/free_run.h"
#include "models/narx/friction_seed.h"
#include "models/narx/narx_structure.h"
#include "models/preprocess/scaling.h"
#include "models/validation/performance.h"
#include "usecases/narx_restarts.h"
#include "models/io/number_text.h"
#include "usecases/request_checks.h"

namespace panelbass::usecases {
namespace {

const std::vector<std::string> kModes{"pem", "oem-s", "oem-d", "oem-n", "oem-ms"};

// The weights the training starts from are a seed's draw (not a model trained on, grown or friction-seeded).
bool fresh_start(const IdentifyNarxRequest& q) { return !q.start_from && q.grow == 0 && q.friction_units.empty(); }

// The measured outputs that set the state of every simulation: the request's, at most a tenth of the shorter part.
Eigen::Index init_of(const IdentifyNarxRequest& q) {
  const Eigen::Index shorter = q.u_val.size() ? std::min(q.u_est.size(), q.u_val.size()) : q.u_est.size();
  return std::min<Eigen::Index>(q.init, shorter / 10);
}

double weight_decay_of(const IdentifyNarxRequest& q) {
  return q.weight_decay ? *q.weight_decay : q.optimizer == "sd" ? 0.0 : models::kDefaultLmWeightDecay;
}

models::TrainingOptions training_options(const IdentifyNarxRequest& q) {
  models::TrainingOptions options;
  options.modes.clear();
  for (const std::string& m : q.modes) options.modes.push_back(models::parse_training_mode(m));
  options.optimizer = models::parse_optimizer(q.optimizer);
  options.max_iterations = q.max_iterations;
  options.pem_max_iterations = q.pem_max_iterations;
  options.pem_min_progress = q.pem_min_progress;
  options.step = q.step;
  options.batch = q.batch;
  options.transient_skip = q.skip;
  options.patience = q.patience;
  options.weight_decay = weight_decay_of(q);
  options.evidence_decay = models::parse_evidence_decay(evidence_decay_of(q));
  options.weights = q.w_est;
  options.validation_weights = q.w_val;
  options.multiple_shooting = q.multiple_shooting;
  // The J reported and the J that early stopping and the kept model go by are one figure: the first `init` measured
  // outputs set the state, then free run (as validate --init).
  options.init = init_of(q);
  return options;
}

// The model training starts from, how its delay was found, and its friction-seeded nodes (null: none).
struct Start {
  models::NarxModel model;
  std::string nk_source;
  nlohmann::json friction = nullptr;
};

Start start_of(const IdentifyNarxRequest& q) {
  Start s;
  if (q.start_from) {
    s.model = *q.start_from;  // its meta is replaced by this run's
    s.nk_source = "the start_from model's";
    return s;
  }
  int nk = q.nk;
  s.nk_source = "given";
  if (nk < 0) {
    const models::DataSurvey survey = models::survey_data(q.u_est, q.y_est);
    nk = survey.delay;
    s.nk_source = models::delay_finding(survey);
  }
  const models::Scaling scaling = models::scaling_from_data(q.u_est, q.y_est);
  s.model = models::NarxModel::with_structure({q.na, q.nb, nk, q.hidden}, scaling, q.fs);
  s.model.net.initialize(1.0, q.seed);  // [5F]
  if (!q.friction_units.empty()) {
    s.friction = models::friction_seed_report(models::seed_friction_units(
        s.model, scaling.scale_u(q.u_est), scaling.scale_y(q.y_est), q.friction_units, q.friction_lags));
  }
  return s;
}

std::string joined(const std::vector<std::string>& list) {
  std::string out;
  for (const std::string& s : list) out += (out.empty() ? "" : ",") + s;
  return out;
}

}  // namespace

std::string evidence_decay_of(const IdentifyNarxRequest& q) {
  return q.evidence_decay ? *q.evidence_decay : q.optimizer == "lm" ? "all" : "off";
}

void check(const IdentifyNarxRequest& q) {
  within("na", q.na, 0, 500);
  within("nb", q.nb, 0, 500);
  within("nk", q.nk, -1, 100000);
  if (q.hidden.empty() || q.hidden.size() > 8) {
    throw RequestError("hidden", "name 1 to 8 layer widths, got " + std::to_string(q.hidden.size()));
  }
  for (const int h : q.hidden) within("hidden", h, 1, 10000);
  if (q.modes.empty()) throw RequestError("modes", "name at least one training mode (pem, oem-s, oem-d, oem-n, oem-ms)");
  for (const std::string& m : q.modes) {
    if (std::find(kModes.begin(), kModes.end(), m) == kModes.end()) {
      throw RequestError("modes", "must be pem, oem-s, oem-d, oem-n or oem-ms, got \"" + m + "\"");
    }
  }
  if (q.optimizer != "lm" && q.optimizer != "sd" && q.optimizer != "linesearch") {
    throw RequestError("optimizer", "must be lm, sd or linesearch, got \"" + q.optimizer + "\"");
  }
  within("max_iterations", q.max_iterations, 0, 1000000);
  within("pem_max_iterations", q.pem_max_iterations, -1, 1000000);
  within_real("pem_min_progress", q.pem_min_progress, 0.0, 0.999);
  if (!(q.step > 0.0 && std::isfinite(q.step))) throw RequestError("step", "must be > 0, got " + models::number_text(q.step));
  within("batch", q.batch, 0, 100000000);
  within("skip", q.skip, -1, 100000000);
  within("patience", q.patience, 1, 1000000);
  if (q.weight_decay) within_real("weight_decay", *q.weight_decay, 0.0, 1e6);
  if (q.optimizer == "sd" && weight_decay_of(q) > 0.0) throw RequestError("weight_decay", "the sd optimizer has none: leave it out or give 0");
  if (q.evidence_decay && *q.evidence_decay != "off" && *q.evidence_decay != "all" && *q.evidence_decay != "oem") {
    throw RequestError("evidence_decay", "must be off, all or oem, got \"" + *q.evidence_decay + "\"");
  }
  if (q.optimizer != "lm" && evidence_decay_of(q) != "off") {
    throw RequestError("evidence_decay", "needs the lm optimizer (the evidence is read off its Gauss-Newton matrix), the optimizer is " +
                                             q.optimizer + ": leave it out or give off");
  }
  within("init", q.init, 0, 1000000);
  within("grow", q.grow, 0, 1000);
  within("friction_units", static_cast<long long>(q.friction_units.size()), 0, 16);
  for (const double g : q.friction_units) {
    if (!(g > 0.0 && g <= 1000.0)) throw RequestError("friction_units", "each gain must be within (0, 1000], got " + models::number_text(g));
  }
  within("friction_lags", q.friction_lags, 1, 100);
  if (!q.friction_units.empty() && static_cast<long long>(q.friction_units.size()) * q.friction_lags > q.hidden.front()) {
    throw RequestError("friction_units", std::to_string(q.friction_units.size()) + " gains x " + std::to_string(q.friction_lags) +
                                             " lags need as many first-layer nodes, hidden[0] is " + std::to_string(q.hidden.front()));
  }
  if (!q.friction_units.empty() && q.grow > 0) throw RequestError("friction_units", "cannot be combined with grow (growth starts afresh)");
  if (q.start_from && !q.friction_units.empty()) {
    throw RequestError("friction_units", "cannot be combined with a start_from model (seeded nodes start afresh)");
  }
  if (q.start_from && q.grow > 0) throw RequestError("grow", "cannot be combined with a start_from model (growth starts afresh)");
  within("multiple_shooting.window", q.multiple_shooting.window, 1, 100000000);
  within_real("multiple_shooting.penalty", q.multiple_shooting.penalty, 1e-12, 1e12);
  within_real("multiple_shooting.penalty_growth", q.multiple_shooting.penalty_growth, 1.0, 1e6);
  within_real("multiple_shooting.penalty_max", q.multiple_shooting.penalty_max, 1e-12, 1e12);
  const bool records = q.u_est.size() > 0;
  const bool validated = q.u_val.size() > 0;
  check_restarts(q.restarts, fresh_start(q), !records || validated);
  if (!records) return;
  if (q.u_est.size() != q.y_est.size() || q.u_val.size() != q.y_val.size()) {
    throw RequestError("record", "a part's drive and response differ in length");
  }
  if ((q.w_est.size() && q.w_est.size() != q.u_est.size()) || (q.w_val.size() && q.w_val.size() != q.u_val.size())) {
    throw RequestError("weighted", "the weights and the record differ in length");
  }
  if (q.prune && !validated) throw RequestError("prune", "needs validation data (the pruning stops by validation J)");
  if (q.start_from && !dsp::same_rate(q.start_from->fs, q.fs)) {
    throw RequestError("start_from", "identified at " + models::number_text(q.start_from->fs) + " Hz, the data is at " +
                                         models::number_text(q.fs) + " Hz");
  }
}

nlohmann::json to_json(const IdentifyNarxRequest& q) {
  return {{"record", q.data_name},
          {"start_from", q.start_from_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(q.start_from_name)},
          {"na", q.na},
          {"nb", q.nb},
          {"nk", q.nk},
          {"hidden", q.hidden},
          {"modes", q.modes},
          {"optimizer", q.optimizer},
          {"max_iterations", q.max_iterations},
          {"pem_max_iterations", q.pem_max_iterations},
          {"pem_min_progress", q.pem_min_progress},
          {"step", q.step},
          {"batch", q.batch},
          {"skip", q.skip},
          {"patience", q.patience},
          {"weight_decay", q.weight_decay ? nlohmann::json(*q.weight_decay) : nlohmann::json(nullptr)},
          {"evidence_decay", q.evidence_decay ? nlohmann::json(*q.evidence_decay) : nlohmann::json(nullptr)},
          {"init", q.init},
          {"seed", q.seed},
          {"restarts", q.restarts},
          {"grow", q.grow},
          {"prune", q.prune},
          {"friction_units", q.friction_units},
          {"friction_lags", q.friction_lags},
          {"multiple_shooting",
           {{"window", q.multiple_shooting.window},
            {"penalty", q.multiple_shooting.penalty},
            {"penalty_growth", q.multiple_shooting.penalty_growth},
            {"penalty_max", q.multiple_shooting.penalty_max}}},
          {"weighted", q.w_est.size() > 0}};
}

IdentifyNarxReport identify_narx(const IdentifyNarxRequest& q, Progress& progress) {
  check(q);
  if (q.u_est.size() == 0) throw RequestError("record", "no estimation samples");
  Start start = start_of(q);
  const models::Scaling& scaling = start.model.scaling;
  const models::NarxStructure structure = start.model.structure;
  const Eigen::VectorXd us = scaling.scale_u(q.u_est), ys = scaling.scale_y(q.y_est);
  const Eigen::VectorXd uv = q.u_val.size() ? scaling.scale_u(q.u_val) : Eigen::VectorXd(),
                        yv = q.y_val.size() ? scaling.scale_y(q.y_val) : Eigen::VectorXd();
  const models::TrainingOptions options = training_options(q);
  const Eigen::Index init = options.init;

  IdentifyNarxReport report;
  nlohmann::json structure_report = nlohmann::json::object();
  models::TrainingResult result;
  std::uint64_t chosen_seed = q.seed;
  ProgressSpan training(progress, 0.0, 0.9);
  if (q.grow > 0) {
    // The thesis's dX/N rule (ch. 6): one hidden node, then one more while it pays.
    models::TrainingOptions growing = options;
    const int total = std::max(1, q.max_iterations * static_cast<int>(options.modes.size()));  // no 0/0
    int done = 0;
    growing.progress = [&](const models::TrainingRecord& r) {
      if (r.iteration > 0) done = std::min(done + 1, total);
      training.report(static_cast<double>(done) / total, "growing: " + models::to_string(r.mode) + " iteration " +
                                                             std::to_string(r.iteration));
    };
    const models::GrowthResult grown =
        models::grow_hidden_nodes(structure, scaling, q.fs, us, ys, uv, yv, growing, q.grow, q.seed);
    result.model = grown.model;
    nlohmann::json steps = nlohmann::json::array();
    for (const auto& g : grown.steps) {
      steps.push_back({{"hidden", g.hidden}, {"params", g.params}, {"J_est_pct", g.j_est_pct},
                       {"J_val_pct", models::number_or_null(g.j_val_pct)}, {"improvement", g.improvement},
                       {"threshold", g.threshold}});
    }
    structure_report["growth"] = {{"chosen_hidden", grown.chosen_hidden}, {"rule", grown.rule}, {"steps", steps}};
  } else {
    // One training, or restarts: the same from other seeds' initial weights ([5F]), the lowest J_val kept.
    NarxRestartsRequest r;
    r.start = start.model;
    r.fresh_start = fresh_start(q);
    r.u_est = q.u_est;
    r.y_est = q.y_est;
    r.u_val = q.u_val;
    r.y_val = q.y_val;
    r.options = options;
    r.seed = q.seed;
    r.restarts = q.restarts;
    NarxRestartsReport trained = train_narx_restarts(r, training);
    result = std::move(trained.result);
    chosen_seed = trained.chosen_seed;
    if (!trained.restarts.is_null()) structure_report["restarts"] = trained.restarts;
  }
  if (q.prune) {
    // Optimal Brain Surgeon with retraining, while validation J stays within 5 % (thesis: remove the redundant
    // parameters).
    progress.report(0.9, "pruning");
    models::PruningOptions pruning;
    pruning.weights = q.w_est;
    pruning.init = init;
    const models::PruningResult pruned = models::prune_obs(result.model, us, ys, uv, yv, pruning);
    result.model = pruned.model;
    structure_report["pruning"] = {{"removed", pruned.removed},
                                   {"params_before", pruned.mask.size()},
                                   {"J_val_before_pct", pruned.j_val_before_pct},
                                   {"J_val_after_pct", pruned.j_val_after_pct},
                                   {"J_est_before_pct", pruned.j_est_before_pct},
                                   {"J_est_after_pct", pruned.j_est_after_pct},
                                   {"stop_reason", pruned.stop_reason}};
  }
  progress.report(0.9, "judging the model");
  // The same protocol as the linear models: the first measured outputs set the state, then free run.
  const auto judged = [&](const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
    return models::j_percent(result.model.simulate(u, y, init), y, init);
  };
  const bool validated = q.u_val.size() > 0;
  const double j_est = judged(q.u_est, q.y_est);
  const double j_val = validated ? judged(q.u_val, q.y_val) : std::numeric_limits<double>::quiet_NaN();
  nlohmann::json history = nlohmann::json::array();
  for (const auto& r : result.history) {
    history.push_back({{"iter", r.iteration}, {"mode", models::to_string(r.mode)}, {"J_est_pct", models::number_or_null(r.j_est_pct)},
                       {"J_val_pct", models::number_or_null(r.j_val_pct)}});
  }
  result.model.meta = {{"data", q.data_name}, {"val", q.val_name}, {"train", joined(q.modes)}, {"optimizer", q.optimizer},
                       {"J_est_pct", j_est}, {"J_val_pct", models::number_or_null(j_val)}, {"seed", chosen_seed},
                       {"weighted", q.w_est.size() > 0}, {"history", history}};
  if (q.start_from) result.model.meta["start_from"] = q.start_from_name;
  if (!start.friction.is_null()) {
    result.model.meta["friction_units"] = start.friction;
    structure_report["friction_units"] = start.friction;
  }
  if (const std::optional<models::Runaway> run = models::free_run_runaway(result.model)) {
    throw std::runtime_error("the trained network's free run on full-scale noise diverges (|y| = " +
                             std::to_string(run->magnitude) + " after " + std::to_string(run->samples) +
                             " samples, scaled units), so no reader would load it. Try fewer hidden nodes, lower orders, "
                             "another seed, or more estimation data");
  }
  progress.report(0.95, "a linear model of the same order on the same record, for comparison");
  const double j_judged = validated ? j_val : j_est;
  const double j_linear = models::linear_reference_j_pct(q.u_est, q.y_est, q.u_val, q.y_val,
                                                         std::max(structure.na, structure.nb), structure.nk,
                                                         std::min<Eigen::Index>(q.init, (validated ? q.u_val : q.u_est).size() / 10));
  report.warnings = models::fit_warnings(j_judged, validated ? "J_val" : "J_est", j_linear,
                                         "Check the delay (nk " + std::to_string(structure.nk) + ", " + start.nk_source +
                                             "); then try more iterations (max_iterations), another seed, or other lags (na, nb).");
  report.summary = {{"J_est_pct", j_est},
                    {"J_val_pct", models::number_or_null(j_val)},
                    {"na", structure.na},
                    {"nb", structure.nb},
                    {"nk", structure.nk},
                    {"nk_source", start.nk_source},
                    {"hidden", result.model.structure.hidden},
                    {"modes", q.modes},
                    {"optimizer", q.optimizer},
                    {"evidence_decay", evidence_decay_of(q)},
                    {"params", result.model.net.parameter_count()},
                    {"iterations", result.iterations},
                    {"seconds", result.seconds},
                    {"weighted", q.w_est.size() > 0},
                    {"linear_reference_J_pct", models::number_or_null(j_linear)},
                    {"structure", structure_report}};
  report.history = std::move(result.history);
  report.model = std::move(result.model);
  progress.report(1.0, "done");
  return report;
}

nlohmann::json narx_gradient_check(const IdentifyNarxRequest& q, long parameter) {
  check(q);
  if (q.u_est.size() == 0) throw RequestError("record", "no estimation samples");
  Start start = start_of(q);
  const models::Scaling& scaling = start.model.scaling;
  const Eigen::VectorXd us = scaling.scale_u(q.u_est), ys = scaling.scale_y(q.y_est);
  const Eigen::VectorXd uv = q.u_val.size() ? scaling.scale_u(q.u_val) : Eigen::VectorXd(),
                        yv = q.y_val.size() ? scaling.scale_y(q.y_val) : Eigen::VectorXd();
  const models::NarxStructure& s = start.model.structure;
  const Eigen::Index skip = q.skip >= 0 ? q.skip : 2 * (s.na + s.nb);
  within("parameter", parameter, 0, start.model.net.parameter_count() - 1);
  // Start from a PEM fit so the comparison is made where training would be (thesis fig. 5.16).
  models::TrainingOptions pem = training_options(q);
  pem.modes = {models::TrainingMode::pem};
  pem.max_iterations = std::min(q.max_iterations, 20);
  const models::NarxModel model = models::train_narx(start.model, us, ys, uv, yv, pem).model;
  return {{"parameter", parameter},
          {"static", models::loss_gradient(model, us, ys, models::TrainingMode::oem_s, skip)[parameter]},
          {"dynamic", models::loss_gradient(model, us, ys, models::TrainingMode::oem_d, skip)[parameter]},
          {"finite_difference", models::loss_gradient(model, us, ys, models::TrainingMode::oem_n, skip)[parameter]}};
}

}  // namespace panelbass::usecases
