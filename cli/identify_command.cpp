#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "cli/usecase_door.h"
#include "dsp/data_file.h"
#include "dsp/sample_rate.h"
#include "models/io/roots_json.h"
#include "models/narx/free_run.h"
#include "models/narx/friction_seed.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/linear_identification.h"
#include "models/kinds/model_file.h"
#include "models/narx/narx_structure.h"
#include "models/narx/narx_training.h"
#include "models/validation/performance.h"
#include "usecases/narx_restarts.h"

namespace panelbass::cli {
namespace {

/// Each of `warnings` on stderr, prefixed by the command.
void print_warnings_prefixed(const std::string& command, const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "%s: warning: %s\n", command.c_str(), w.c_str());
}

struct IdentifyLinearOptions {
  std::string data, val, out;
  DataOptions columns;
  std::string method = "zhu";
  int order = 8;
  int delay = -1;
  std::string scan;
  long init = 50;
  int decimation = 1;
  int max_iterations = 100;
};

void run_identify_linear(const IdentifyLinearOptions& o) {
  const dsp::Record est = o.columns.read(o.data);
  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(o.method);
  spec.order = o.order;
  spec.delay = o.delay;
  spec.init = o.init;
  spec.fs = est.fs;
  spec.decimation = o.decimation;
  spec.oe.max_iterations = o.max_iterations;
  if (!o.scan.empty()) {
    const auto colon = o.scan.find(':');
    if (colon == std::string::npos) throw std::invalid_argument("--scan expects FROM:TO, got \"" + o.scan + "\"");
    spec.scan_from = std::stoi(o.scan.substr(0, colon));
    spec.scan_to = std::stoi(o.scan.substr(colon + 1));
  }
  const DataOptions::Validation val = o.columns.read_optional_validation(o.val, est.fs);
  const Eigen::VectorXd &u_val = val.u, &y_val = val.y;
  ProgressBar bar("identify " + o.method);
  spec.progress = [&bar, &spec](const std::string& stage, double f) {
    bar.update(models::identification_fraction(spec, stage, f));
  };
  models::LinearIdentification id = models::identify_linear(est.columns[0], est.columns[1], u_val, y_val, spec);
  bar.update(1.0);

  nlohmann::json scan = nlohmann::json::array();
  for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
  id.model.meta = {{"data", o.data},
                   {"val", o.val},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", models::number_or_null(id.j_val_pct)}};
  models::save_linear_model(o.out, id.model);

  nlohmann::json result = {{"method", o.method},
                           {"order", id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb()},
                           {"J_est_pct", id.j_est_pct},
                           {"J_val_pct", models::number_or_null(id.j_val_pct)},
                           {"J_pred_est_pct", id.j_pred_est_pct},
                           {"delay", id.model.tf.nk},
                           {"nk_source", id.nk_source},
                           {"poles", models::roots_json(id.model.tf.poles())},
                           {"zeros", models::roots_json(id.model.tf.zeros())},
                           {"survey", models::data_survey_to_json(id.survey)},
                           {"out", o.out}};
  if (!id.scan.empty()) {
    result["scan"] = scan;
    result["order_rule"] = id.order_rule;
    result["scan_skipped"] = id.scan_skipped;
    for (const std::string& why : id.scan_skipped) std::fprintf(stderr, "identify linear: scan skipped %s\n", why.c_str());
  }
  const bool validated = u_val.size() > 0;
  print_warnings_prefixed(
      "identify linear",
      models::fit_warnings(validated ? id.j_val_pct : id.j_est_pct, validated ? "J_val" : "J_est",
                           std::numeric_limits<double>::quiet_NaN(),
                           "Check the delay (--delay; " + std::to_string(id.model.tf.nk) + ", " + id.nk_source +
                               "); then try another --method, an order --scan, or more --max-iter."));
  print_result(result);
}

struct IdentifyNarxOptions {
  std::string data, val, out;
  DataOptions columns;
  int na = 8, nb = 8, nk = 0;
  std::vector<int> hidden{17};
  std::string train = "pem,oem-d";
  std::string optimizer = "lm";
  int max_iterations = 100;
  int pem_max_iterations = models::TrainingOptions{}.pem_max_iterations;  ///< --pem-max-iter
  double pem_min_progress = models::kDefaultPemMinProgress;               ///< --pem-min-progress
  std::uint64_t seed = 1;
  double step = 0.1;
  long batch = 0;
  long skip = -1;
  int patience = 20;
  double weight_decay = models::kDefaultLmWeightDecay;  ///< --weight-decay; 0 with --optimizer sd unless given (issue 59's measurements)
  bool gradient_check = false;
  long parameter = 0;
  long init = 50;
  int grow = 0;
  int restarts = 1;  ///< --restarts: trainings from seeds seed … seed + restarts − 1, the lowest J_val kept
  bool prune = false;
  std::string weight_col;
  std::vector<double> friction_gains;
  int friction_lags = 1;
  std::string start_from;
  std::string history_out;       ///< --history: the training history as JSON there (else on stderr)
  bool structure_given = false;  ///< --na, --nb, --nk or --hidden on the command line
  bool nk_given = false;         ///< --nk on the command line
  models::MultipleShootingOptions multiple_shooting;  ///< --ms-window, --ms-penalty, … (oem-ms)
};

std::vector<models::TrainingMode> parse_modes(const std::string& list) {
  std::vector<models::TrainingMode> modes;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = list.find(',', start);
    modes.push_back(models::parse_training_mode(list.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return modes;
}

/// The weight column `name` of `path`, read at rate fs (empty name: none).
Eigen::VectorXd read_weights(const std::string& path, const std::string& name, double fs) {
  if (name.empty()) return {};
  return dsp::read_data_file(path, {name}, fs, 10).columns[0];
}

/// A model of the options' structure scaled to the estimation record, its weights drawn from --seed ([5F]).
models::NarxModel fresh_narx_model(const IdentifyNarxOptions& o, const dsp::Record& est) {
  const models::Scaling scaling = models::scaling_from_data(est.columns[0], est.columns[1]);
  models::NarxModel model = models::NarxModel::with_structure({o.na, o.nb, o.nk, o.hidden}, scaling, est.fs);
  model.net.initialize(1.0, o.seed);
  return model;
}

/// --start-from: the given model, structure, scaling and weights, to train on from where it is (say on new
/// records); refused for another rate, or with what only a fresh start uses.
models::NarxModel start_narx_model(const IdentifyNarxOptions& o, double fs) {
  const models::AnyModel any = models::load_model(o.start_from);
  const auto* start = std::get_if<models::NarxModel>(&any.model);
  if (start == nullptr) throw std::invalid_argument("--start-from " + o.start_from + ": expected a NARX model, got " + any.kind());
  if (!dsp::same_rate(start->fs, fs)) {
    throw std::invalid_argument("--start-from " + o.start_from + ": identified at " + std::to_string(start->fs) +
                                " Hz, the data is at " + std::to_string(fs) + " Hz");
  }
  if (o.structure_given) throw std::invalid_argument("--start-from takes the model's structure: leave out --na, --nb, --nk and --hidden");
  if (o.grow > 0 || !o.friction_gains.empty()) {
    throw std::invalid_argument("--start-from cannot be combined with --grow or --friction-units (they start afresh)");
  }
  return *start;  // its meta is replaced by this run's when the model is written
}

void run_identify_narx(const IdentifyNarxOptions& o) {
  const dsp::Record est = o.columns.read(o.data);
  Eigen::VectorXd u_val, y_val, w_val;
  if (!o.val.empty()) {
    const dsp::Record val = o.columns.read_validation(o.val, est.fs);
    u_val = val.columns[0];
    y_val = val.columns[1];
    w_val = read_weights(o.val, o.weight_col, est.fs);
  }
  const Eigen::VectorXd w_est = read_weights(o.data, o.weight_col, est.fs);
  const bool fresh_start = o.start_from.empty() && o.grow == 0 && o.friction_gains.empty();
  run_use_case([&] { usecases::check_restarts(o.restarts, fresh_start, !o.val.empty()); });
  models::NarxModel model = o.start_from.empty() ? fresh_narx_model(o, est) : start_narx_model(o, est.fs);
  const models::Scaling& scaling = model.scaling;
  const models::NarxStructure& structure = model.structure;
  const Eigen::VectorXd us = scaling.scale_u(est.columns[0]), ys = scaling.scale_y(est.columns[1]);
  nlohmann::json friction_report = nullptr;
  if (!o.friction_gains.empty()) {
    if (o.grow > 0) throw std::invalid_argument("--friction-units cannot be combined with --grow (growth starts afresh)");
    friction_report =
        models::friction_seed_report(models::seed_friction_units(model, us, ys, o.friction_gains, o.friction_lags));
  }
  const Eigen::VectorXd uv = u_val.size() ? scaling.scale_u(u_val) : Eigen::VectorXd(),
                        yv = y_val.size() ? scaling.scale_y(y_val) : Eigen::VectorXd();
  models::TrainingOptions options;
  options.modes = parse_modes(o.train);
  options.optimizer = models::parse_optimizer(o.optimizer);
  options.max_iterations = o.max_iterations;
  options.pem_max_iterations = o.pem_max_iterations;
  options.pem_min_progress = o.pem_min_progress;
  options.step = o.step;
  options.batch = o.batch;
  options.transient_skip = o.skip;
  options.patience = o.patience;
  options.weight_decay = o.weight_decay;
  options.weights = w_est;
  options.validation_weights = w_val;
  options.multiple_shooting = o.multiple_shooting;
  // The J reported below and the J that early stopping and the kept model go by are one figure: the first
  // `init` measured outputs set the state, then free run (as validate --init).
  const Eigen::Index init =
      std::min<Eigen::Index>(o.init, std::min(us.size(), uv.size() ? uv.size() : us.size()) / 10);
  options.init = init;
  if (o.gradient_check) {
    const Eigen::Index skip = o.skip >= 0 ? o.skip : 2 * (structure.na + structure.nb);
    if (o.parameter < 0 || o.parameter >= model.net.parameter_count()) {
      throw std::invalid_argument("--parameter must be within [0, " + std::to_string(model.net.parameter_count()) + ")");
    }
    // Start from a PEM fit so the comparison is made where training would be (thesis fig. 5.16).
    models::TrainingOptions pem = options;
    pem.modes = {models::TrainingMode::pem};
    pem.max_iterations = std::min(o.max_iterations, 20);
    model = models::train_narx(model, us, ys, uv, yv, pem).model;
    const auto p = o.parameter;
    print_result({{"parameter", p},
                  {"static", models::loss_gradient(model, us, ys, models::TrainingMode::oem_s, skip)[p]},
                  {"dynamic", models::loss_gradient(model, us, ys, models::TrainingMode::oem_d, skip)[p]},
                  {"finite_difference", models::loss_gradient(model, us, ys, models::TrainingMode::oem_n, skip)[p]}});
    return;
  }
  BarProgress bar("identify narx");
  nlohmann::json structure_report = nlohmann::json::object();
  models::TrainingResult result;
  std::uint64_t chosen_seed = o.seed;
  if (o.grow > 0) {
    // The thesis's dX/N rule (ch. 6): one hidden node, then one more while it pays.
    const int total = std::max(1, o.max_iterations * static_cast<int>(options.modes.size()));  // no 0/0
    int done = 0;
    options.progress = [&](const models::TrainingRecord& r) {
      if (r.iteration > 0) ++done;
      bar.report(static_cast<double>(done) / total, "");
    };
    const models::GrowthResult grown =
        models::grow_hidden_nodes(structure, scaling, est.fs, us, ys, uv, yv, options, o.grow, o.seed);
    result.model = grown.model;
    nlohmann::json steps = nlohmann::json::array();
    for (const auto& g : grown.steps) {
      steps.push_back({{"hidden", g.hidden}, {"params", g.params}, {"J_est_pct", g.j_est_pct},
                       {"J_val_pct", models::number_or_null(g.j_val_pct)}, {"improvement", g.improvement}, {"threshold", g.threshold}});
    }
    structure_report["growth"] = {{"chosen_hidden", grown.chosen_hidden}, {"rule", grown.rule}, {"steps", steps}};
  } else {
    // One training, or --restarts: the same from other seeds' initial weights ([5F]), the lowest J_val kept.
    usecases::NarxRestartsRequest q;
    q.start = model;
    q.fresh_start = fresh_start;
    q.u_est = est.columns[0];
    q.y_est = est.columns[1];
    q.u_val = u_val;
    q.y_val = y_val;
    q.options = options;
    q.seed = o.seed;
    q.restarts = o.restarts;
    usecases::NarxRestartsReport trained = run_use_case([&] { return usecases::train_narx_restarts(q, bar); });
    result = std::move(trained.result);
    chosen_seed = trained.chosen_seed;
    if (!trained.restarts.is_null()) structure_report["restarts"] = trained.restarts;
  }
  if (o.prune) {
    if (uv.size() == 0) throw std::invalid_argument("--prune needs validation data (--val)");
    // Optimal Brain Surgeon with retraining, while validation J stays within 5 % (thesis: remove the
    // redundant parameters).
    models::PruningOptions pruning;
    pruning.weights = w_est;
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
  bar.report(1.0, "done");
  nlohmann::json history = nlohmann::json::array();
  for (const auto& r : result.history) {
    history.push_back({{"iter", r.iteration}, {"mode", models::to_string(r.mode)}, {"J_est_pct", models::number_or_null(r.j_est_pct)},
                       {"J_val_pct", models::number_or_null(r.j_val_pct)}});
  }
  // The same protocol as the linear models: the first measured outputs set the state, then free run.
  const auto judged = [&](const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
    return models::j_percent(result.model.simulate(u, y, init), y, init);
  };
  const double j_est = judged(est.columns[0], est.columns[1]);
  const double j_val = u_val.size() ? judged(u_val, y_val) : std::numeric_limits<double>::quiet_NaN();
  result.model.meta = {{"data", o.data}, {"val", o.val}, {"train", o.train}, {"optimizer", o.optimizer},
                       {"J_est_pct", j_est}, {"J_val_pct", models::number_or_null(j_val)}, {"seed", chosen_seed}};
  if (!o.start_from.empty()) result.model.meta["start_from"] = o.start_from;
  if (!friction_report.is_null()) {
    result.model.meta["friction_units"] = friction_report;
    structure_report["friction_units"] = friction_report;
  }
  if (const std::optional<models::Runaway> run = models::free_run_runaway(result.model)) {
    throw std::runtime_error("identify narx: no model written to " + o.out +
                             ": the trained network's free run on full-scale noise diverges (|y| = " +
                             std::to_string(run->magnitude) + " after " + std::to_string(run->samples) +
                             " samples, scaled units), so no reader would load it. Try fewer hidden nodes, lower orders, "
                             "another --seed, or more estimation data");
  }
  models::save_narx_model(o.out, result.model);
  // The history is a log, not the result: a file on request, else stderr.
  if (!o.history_out.empty()) {
    models::write_json_file(o.history_out, {{"history", history}});
  } else {
    for (const auto& r : result.history) {
      std::fprintf(stderr, "identify narx: %s iteration %d: J_est %.4g %%, J_val %.4g %%\n", models::to_string(r.mode).c_str(),
                   r.iteration, r.j_est_pct, r.j_val_pct);
    }
  }
  const std::string nk_source = !o.start_from.empty() ? "the --start-from model's"
                                : o.nk_given          ? "given (--nk)"
                                                      : "the default of --nk (no dead time)";
  const bool validated = u_val.size() > 0;
  const double j_judged = validated ? j_val : j_est;
  const double j_linear = models::linear_reference_j_pct(est.columns[0], est.columns[1], u_val, y_val,
                                                         std::max(structure.na, structure.nb), structure.nk,
                                                         std::min<Eigen::Index>(o.init, (validated ? u_val : est.columns[0]).size() / 10));
  print_warnings_prefixed("identify narx",
                          models::fit_warnings(j_judged, validated ? "J_val" : "J_est", j_linear,
                                               "Check the delay (--nk " + std::to_string(structure.nk) + ", " + nk_source +
                                                   "); then try more --max-iter, another --seed, or other --na/--nb."));
  print_result({{"J_est_pct", j_est},
                {"J_val_pct", models::number_or_null(j_val)},
                {"iterations", result.iterations},
                {"seconds", result.seconds},
                {"params", result.model.net.parameter_count()},
                {"structure", structure_report},
                {"nk", structure.nk},
                {"nk_source", nk_source},
                {"linear_reference_J_pct", models::number_or_null(j_linear)},
                {"history_out", o.history_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.history_out)},
                {"out", o.out}});
}

}  // namespace

void register_identify(CLI::App& app) {
  CLI::App* identify = app.add_subcommand("identify", "Identify a model from measured data");
  identify->require_subcommand(1);
  identify->footer("Example:\n  panelbass identify linear --data est.csv --val val.csv --fs 3000 --method zhu --order 8 --out lin.json");

  auto o = std::make_shared<IdentifyLinearOptions>();
  CLI::App* linear = identify->add_subcommand("linear", "Linear model by FIR, ARX, OE, Zhu's method or FIR-Hankel-OE (Backx)");
  linear->add_option("--data", o->data, "Estimation data, .csv or .wav")->required();
  linear->add_option("--val", o->val, "Validation data (for J_val and --scan)");
  o->columns.add_to(linear);
  linear->add_option("--method", o->method, "fir, arx, oe, zhu or backx")
      ->check(CLI::IsMember({"fir", "arx", "oe", "zhu", "backx"}))
      ->capture_default_str();
  linear->add_option("--order", o->order, "Model order (na = nb; FIR: taps)")->check(CLI::Range(1, 5000))->capture_default_str();
  linear->add_option("--delay", o->delay, "Input delay nk in samples (default: estimated)")->check(CLI::Range(0, 100000));
  linear->add_option("--scan", o->scan, "Order scan FROM:TO, e.g. 1:16 (keeps the order the rule picks)");
  linear->add_option("--init", o->init, "Measured outputs that set the state before J is computed")
      ->check(CLI::Range(0L, 1000000L))
      ->capture_default_str();
  linear->add_option("--decimate", o->decimation, "Backx: decimation factor before the FIR step")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  linear->add_option("--max-iter", o->max_iterations, "Output-error iterations")->check(CLI::Range(1, 100000))->capture_default_str();
  linear->add_option("--out", o->out, "Model file to write (JSON)")->required();
  linear->footer(
      "Example:\n  panelbass simulate --samples 12000 --out run.csv\n"
      "  panelbass identify linear --data run.csv --fs 3000 --method zhu --scan 1:12 --val run.csv --out lin.json");
  linear->callback([o] { run_identify_linear(*o); });

  auto n = std::make_shared<IdentifyNarxOptions>();
  CLI::App* narx = identify->add_subcommand("narx", "Neural NARX model trained on its simulation error (thesis ch. 5-6)");
  narx->add_option("--data", n->data, "Estimation data, .csv or .wav")->required();
  narx->add_option("--val", n->val, "Validation data (early stopping and J_val)");
  n->columns.add_to(narx);
  narx->add_option("--na", n->na, "Past outputs y(k-1)..y(k-na)")->check(CLI::Range(0, 500))->capture_default_str();
  narx->add_option("--nb", n->nb, "Past inputs u(k-nk)..u(k-nk-nb)")->check(CLI::Range(0, 500))->capture_default_str();
  narx->add_option("--nk", n->nk, "Input delay")->check(CLI::Range(0, 100000))->capture_default_str();
  narx->add_option("--hidden", n->hidden, "Hidden layer widths, e.g. 17 or 17,8")->delimiter(',')->check(CLI::Range(1, 10000));
  narx->add_option("--train", n->train, "Modes in order: pem, oem-s, oem-d, oem-n, oem-ms (multiple shooting), comma-separated")
      ->capture_default_str();
  narx->add_option("--optimizer", n->optimizer, "lm, sd or linesearch")
      ->check(CLI::IsMember({"lm", "sd", "linesearch"}))
      ->capture_default_str();
  narx->add_option("--max-iter", n->max_iterations, "Iterations per mode")->check(CLI::Range(0, 1000000))->capture_default_str();
  narx->add_option("--pem-max-iter", n->pem_max_iterations, "The pem mode's own limit (-1: --max-iter)")
      ->check(CLI::Range(-1, 1000000))
      ->capture_default_str();
  narx->add_option("--pem-min-progress", n->pem_min_progress,
                   "pem also stops once its best validation J fell by less than this fraction over its last 10 "
                   "iterations, leaving them to the output-error mode (0: off)")
      ->check(CLI::Range(0.0, 0.999))
      ->capture_default_str();
  narx->add_option("--seed", n->seed, "Seed of the initial weights ([5F])")->capture_default_str();
  narx->add_option("--step", n->step, "Steepest-descent step alpha")->check(CLI::PositiveNumber)->capture_default_str();
  narx->add_option("--batch", n->batch, "Steepest-descent batch L (0 = all samples)")->check(CLI::Range(0L, 100000000L));
  narx->add_option("--skip", n->skip, "Transient skip [5M] (default 2(na+nb))")->check(CLI::Range(0L, 100000000L));
  narx->add_option("--patience", n->patience, "Iterations without validation improvement before stopping")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  narx->add_option("--weight-decay", n->weight_decay,
                   "Weight decay D (NNSYSID's): lm and linesearch minimise (sum e^2 + D*|theta|^2)/(2N) on scaled data; "
                   "with --optimizer sd the default is 0 (sd has none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  narx->add_option("--init", n->init,
                   "Measured outputs that set the state before J is computed (at most a tenth of the shorter record); "
                   "training's simulations, early stopping and the kept model go by the same J")
      ->check(CLI::Range(0L, 1000000L))
      ->capture_default_str();
  narx->add_option("--grow", n->grow, "Grow the hidden layer from 1 node up to N by the thesis's dX/N rule")
      ->check(CLI::Range(1, 1000));
  narx->add_option("--restarts", n->restarts,
                   "Train from N seeds' initial weights (--seed, --seed + 1, ...) and keep the model of the lowest J_val "
                   "(needs --val); seconds and iterations are the total")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  narx->add_flag("--prune", n->prune, "Prune redundant weights by Optimal Brain Surgeon with retraining (needs --val)");
  narx->add_flag("--gradient-check", n->gradient_check,
                 "Print the static, dynamic and finite-difference gradients of one parameter (fig. 5.16)");
  narx->add_option("--parameter", n->parameter, "Parameter index for --gradient-check")->capture_default_str();
  narx->add_option("--weight-col", n->weight_col,
                   "Column of per-sample weights of the loss, in --data and --val (e.g. w of simulate --signal control); "
                   "J figures stay unweighted, early stopping watches the weighted J_val");
  narx->add_option("--friction-units", n->friction_gains,
                   "Seed the first hidden nodes as Coulomb friction tanh(g*v), v the velocity estimated from the "
                   "regressor, one node per sharpness g (e.g. 3,10); training then adjusts them")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  narx->add_option("--friction-lags", n->friction_lags,
                   "With --friction-units: seed the nodes for the velocities v(k)..v(k-L+1) too (L x gains nodes)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  narx->add_option("--start-from", n->start_from,
                   "Train on from this NARX model (its structure, scaling and weights), e.g. on new records; --seed then "
                   "plays no part");
  // oem-ms (multiple shooting): its windows and continuity penalty; refused unless --train has oem-ms
  const std::vector<std::string> multiple_shooting_flags{"--ms-window", "--ms-penalty", "--ms-penalty-growth",
                                                         "--ms-penalty-max"};
  narx->add_option("--ms-window", n->multiple_shooting.window,
                   "oem-ms: samples per window (>= na), each simulated from a free initial output history")
      ->check(CLI::Range(1L, 100000000L))
      ->capture_default_str();
  narx->add_option("--ms-penalty", n->multiple_shooting.penalty,
                   "oem-ms: weight rho of a continuity residual (window start against the previous window's end) "
                   "against one sample's error, at the start")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  narx->add_option("--ms-penalty-growth", n->multiple_shooting.penalty_growth,
                   "oem-ms: rho times this after every accepted step (1 = constant)")
      ->check(CLI::Range(1.0, 1e6))
      ->capture_default_str();
  narx->add_option("--ms-penalty-max", n->multiple_shooting.penalty_max, "oem-ms: rho grows no further")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  narx->add_option("--out", n->out, "Model file to write (JSON)");
  narx->add_option("--history", n->history_out,
                   "Write the training history (J per iteration) to this JSON file, {\"history\": [...]}, the form analyze "
                   "--history reads; without it the history goes to stderr");
  narx->footer(
      "Example (the best recipe measured, docs/identification.md):\n  panelbass identify narx --data est.csv --val val.csv "
      "--fs 3000 --na 8 --nb 8 --hidden 17 --train pem,oem-d --optimizer lm --weight-decay 0.01 --max-iter 200 --seed 1 "
      "--out nn.json\n"
      "  panelbass identify narx --data est.csv --val val.csv --fs 3000 --train pem,oem-ms,oem-d --ms-window 250 "
      "--out nn-ms.json\n"
      "  panelbass identify narx --data more.csv --val val.csv --fs 3000 --start-from nn.json --train oem-d "
      "--max-iter 20 --out nn2.json");
  narx->callback([n, narx, multiple_shooting_flags] {
    for (const char* name : {"--na", "--nb", "--nk", "--hidden"}) n->structure_given |= narx->count(name) > 0;
    n->nk_given = narx->count("--nk") > 0;
    if (narx->count("--weight-decay") == 0 && n->optimizer == "sd") n->weight_decay = 0.0;
    for (const std::string& flag : multiple_shooting_flags) {
      if (narx->count(flag) > 0 && n->train.find("oem-ms") == std::string::npos) {
        throw std::invalid_argument(flag + " applies to the oem-ms stage: add oem-ms to --train (e.g. pem,oem-ms,oem-d)");
      }
    }
    if (!n->gradient_check && n->out.empty()) throw CLI::RequiredError("--out");
    run_identify_narx(*n);
  });

  register_identify_ss(*identify);
  register_identify_oscillator(*identify);
  register_identify_average(*identify);
  register_identify_mimo(*identify);
}

}  // namespace panelbass::cli
