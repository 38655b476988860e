// `panelbass identify` and its `linear` and `narx` verbs (usecases/identify_linear.h, usecases/identify_narx.h); the
// other identify verbs register from their own files.

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "models/narx/narx_training.h"
#include "usecases/identify_linear.h"
#include "usecases/identify_narx.h"

namespace panelbass::cli {
namespace {

/// Each of `warnings` on stderr, prefixed by the command.
void print_warnings_prefixed(const std::string& command, const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "%s: warning: %s\n", command.c_str(), w.c_str());
}

// The options of `identify linear`; the defaults are the request's (usecases::IdentifyLinearRequest).
struct IdentifyLinearOptions {
  std::string data, val, out, scan;
  DataOptions columns;
  usecases::IdentifyLinearRequest q;  ///< the flags' values (records filled in by run_identify_linear)
};

void run_identify_linear(IdentifyLinearOptions o) {
  usecases::IdentifyLinearRequest& q = o.q;
  if (!o.scan.empty()) {
    const auto colon = o.scan.find(':');
    if (colon == std::string::npos) throw std::invalid_argument("--scan expects FROM:TO, got \"" + o.scan + "\"");
    q.scan = {std::stoi(o.scan.substr(0, colon)), std::stoi(o.scan.substr(colon + 1))};
  }
  const RequestSpelling spelling{{{"record", "--data"}, {"decimation", "--decimate"}, {"max_iterations", "--max-iter"}},
                                 {{"record", o.data}}};
  run_use_case([&] { usecases::check(q); }, spelling);  // a bad flag before the records are read
  o.columns.read_into(q, o.data, o.val);
  BarProgress bar("identify " + q.method);
  const usecases::IdentifyLinearReport report = run_use_case([&] { return usecases::identify_linear(q, bar); }, spelling);
  models::save_linear_model(o.out, report.model);
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  if (result.contains("scan_skipped")) {
    for (const auto& why : result.at("scan_skipped")) {
      std::fprintf(stderr, "identify linear: scan skipped %s\n", why.get<std::string>().c_str());
    }
  }
  print_warnings_prefixed("identify linear", report.warnings);
  print_result(result);
}

/// The entries of `list` joined by `separator`.
std::string joined(const std::vector<std::string>& list, const std::string& separator) {
  std::string out;
  for (const std::string& s : list) out += (out.empty() ? "" : separator) + s;
  return out;
}

// The options of `identify narx`; the defaults are the request's (usecases::IdentifyNarxRequest).
struct IdentifyNarxOptions {
  std::string data, val, out, start_from, weight_col;
  std::string history_out;  ///< --history: the training history as JSON there (else on stderr)
  DataOptions columns;
  usecases::IdentifyNarxRequest q;  ///< the flags' values (records and models filled in by run_identify_narx)
  std::string train = joined(usecases::IdentifyNarxRequest{}.modes, ",");  ///< --train, comma-separated
  double weight_decay = models::kDefaultLmWeightDecay;  ///< --weight-decay (q.weight_decay when given)
  std::string evidence_decay = usecases::evidence_decay_of(usecases::IdentifyNarxRequest{});  ///< --evidence-decay (q.evidence_decay when given)
  bool gradient_check = false;
  long parameter = 0;
};

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = list.find(',', start);
    items.push_back(list.substr(start, comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return items;
}

/// The weight column `name` of `path`, read at rate fs (empty name: none).
Eigen::VectorXd read_weights(const std::string& path, const std::string& name, double fs) {
  if (name.empty() || path.empty()) return {};
  return dsp::read_data_file(path, {name}, fs, 10).columns[0];
}

void run_identify_narx(IdentifyNarxOptions o) {
  usecases::IdentifyNarxRequest& q = o.q;
  q.modes = split_list(o.train);
  const RequestSpelling spelling{{{"record", "--data"},
                                  {"modes", "--train"},
                                  {"max_iterations", "--max-iter"},
                                  {"pem_max_iterations", "--pem-max-iter"},
                                  {"weighted", "--weight-col"},
                                  {"multiple_shooting.window", "--ms-window"},
                                  {"multiple_shooting.penalty", "--ms-penalty"},
                                  {"multiple_shooting.penalty_growth", "--ms-penalty-growth"},
                                  {"multiple_shooting.penalty_max", "--ms-penalty-max"}},
                                 {{"record", o.data}}};
  run_use_case([&] { usecases::check(q); }, spelling);  // a bad flag before the records are read
  o.columns.read_into(q, o.data, o.val);
  q.w_est = read_weights(o.data, o.weight_col, q.fs);
  q.w_val = read_weights(o.val, o.weight_col, q.fs);
  if (!o.start_from.empty()) {
    const models::AnyModel any = models::load_model(o.start_from);
    const auto* start = std::get_if<models::NarxModel>(&any.model);
    if (start == nullptr) throw std::invalid_argument("--start-from " + o.start_from + ": expected a NARX model, got " + any.kind());
    q.start_from = *start;
    q.start_from_name = o.start_from;
  }
  if (o.gradient_check) {
    print_result(run_use_case([&] { return usecases::narx_gradient_check(q, o.parameter); }, spelling));
    return;
  }
  BarProgress bar("identify narx");
  usecases::IdentifyNarxReport report;
  try {
    report = run_use_case([&] { return usecases::identify_narx(q, bar); }, spelling);
  } catch (const CLI::Error&) {
    throw;  // a refused flag (a usage error)
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("identify narx: no model written to " + o.out + ": " + e.what());
  }
  models::save_narx_model(o.out, report.model);
  // The history is a log, not the result: a file on request, else stderr.
  if (!o.history_out.empty()) {
    models::write_json_file(o.history_out, {{"history", report.model.meta.at("history")}});
  } else {
    for (const auto& r : report.history) {
      std::fprintf(stderr, "identify narx: %s iteration %d: J_est %.4g %%, J_val %.4g %%\n", models::to_string(r.mode).c_str(),
                   r.iteration, r.j_est_pct, r.j_val_pct);
    }
  }
  print_warnings_prefixed("identify narx", report.warnings);
  nlohmann::json result = report.summary;
  result["history_out"] = o.history_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.history_out);
  result["out"] = o.out;
  print_result(result);
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
  linear->add_option("--method", o->q.method, "fir, arx, oe, zhu or backx")->capture_default_str();
  linear->add_option("--order", o->q.order, "Model order (na = nb; FIR: taps)")->capture_default_str();
  linear->add_option("--delay", o->q.delay, "Input delay nk in samples (-1: estimated)")->capture_default_str();
  linear->add_option("--scan", o->scan, "Order scan FROM:TO, e.g. 1:16 (keeps the order the rule picks)");
  linear->add_option("--init", o->q.init, "Measured outputs that set the state before J is computed")
      ->capture_default_str();
  linear->add_option("--decimate", o->q.decimation, "Backx: decimation factor before the FIR step")
      ->capture_default_str();
  linear->add_option("--max-iter", o->q.max_iterations, "Output-error iterations")->capture_default_str();
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
  narx->add_option("--na", n->q.na, "Past outputs y(k-1)..y(k-na)")->capture_default_str();
  narx->add_option("--nb", n->q.nb, "Past inputs u(k-nk)..u(k-nk-nb)")->capture_default_str();
  narx->add_option("--nk", n->q.nk, "Input delay (-1: estimated from the data)")->capture_default_str();
  narx->add_option("--hidden", n->q.hidden, "Hidden layer widths, e.g. 17 or 17,8")->delimiter(',')->capture_default_str();
  narx->add_option("--train", n->train, "Modes in order: pem, oem-s, oem-d, oem-n, oem-ms (multiple shooting), comma-separated")
      ->capture_default_str();
  narx->add_option("--optimizer", n->q.optimizer, "lm, sd or linesearch")
      ->capture_default_str();
  narx->add_option("--max-iter", n->q.max_iterations, "Iterations per mode")->capture_default_str();
  narx->add_option("--pem-max-iter", n->q.pem_max_iterations, "The pem mode's own limit (-1: --max-iter)")
      ->capture_default_str();
  narx->add_option("--pem-min-progress", n->q.pem_min_progress,
                   "pem also stops once its best validation J fell by less than this fraction over its last 10 "
                   "iterations, leaving them to the output-error mode (0: off)")
      ->capture_default_str();
  narx->add_option("--seed", n->q.seed, "Seed of the initial weights ([5F])")->capture_default_str();
  narx->add_option("--step", n->q.step, "Steepest-descent step alpha")->capture_default_str();
  narx->add_option("--batch", n->q.batch, "Steepest-descent batch L (0 = all samples)")->capture_default_str();
  narx->add_option("--skip", n->q.skip, "Transient skip [5M] (-1: 2(na+nb))")->capture_default_str();
  narx->add_option("--patience", n->q.patience, "Iterations without validation improvement before stopping")
      ->capture_default_str();
  narx->add_option("--weight-decay", n->weight_decay,
                   "Weight decay D (NNSYSID's): lm and linesearch minimise (sum e^2 + D*|theta|^2)/(2N) on scaled data; "
                   "with --optimizer sd the default is 0 (sd has none); with --evidence-decay all or oem, the starting D")
      ->capture_default_str();
  narx->add_option("--evidence-decay", n->evidence_decay,
                   "off, all or oem: re-estimate D after each lm iteration by MacKay's evidence, in all modes or in the "
                   "output-error modes alone (pem keeps --weight-decay); the default with --optimizer sd or linesearch is off")
      ->capture_default_str();
  narx->add_option("--init", n->q.init,
                   "Measured outputs that set the state before J is computed (at most a tenth of the shorter record); "
                   "training's simulations, early stopping and the kept model go by the same J")
      ->capture_default_str();
  narx->add_option("--grow", n->q.grow, "Grow the hidden layer from 1 node up to N by the thesis's dX/N rule");
  narx->add_option("--restarts", n->q.restarts,
                   "Train from N seeds' initial weights (--seed, --seed + 1, ...) and keep the model of the lowest J_val "
                   "(needs --val); seconds and iterations are the total")
      ->capture_default_str();
  narx->add_flag("--prune", n->q.prune, "Prune redundant weights by Optimal Brain Surgeon with retraining (needs --val)");
  narx->add_flag("--gradient-check", n->gradient_check,
                 "Print the static, dynamic and finite-difference gradients of one parameter (fig. 5.16)");
  narx->add_option("--parameter", n->parameter, "Parameter index for --gradient-check")->capture_default_str();
  narx->add_option("--weight-col", n->weight_col,
                   "Column of per-sample weights of the loss, in --data and --val (e.g. w of simulate --signal control); "
                   "J figures stay unweighted, early stopping watches the weighted J_val");
  narx->add_option("--friction-units", n->q.friction_units,
                   "Seed the first hidden nodes as Coulomb friction tanh(g*v), v the velocity estimated from the "
                   "regressor, one node per sharpness g (e.g. 3,10); training then adjusts them")
      ->delimiter(',');
  narx->add_option("--friction-lags", n->q.friction_lags,
                   "With --friction-units: seed the nodes for the velocities v(k)..v(k-L+1) too (L x gains nodes)")
      ->capture_default_str();
  narx->add_option("--start-from", n->start_from,
                   "Train on from this NARX model (its structure, scaling and weights), e.g. on new records; --seed then "
                   "plays no part");
  // oem-ms (multiple shooting): its windows and continuity penalty; refused unless --train has oem-ms
  const std::vector<std::string> multiple_shooting_flags{"--ms-window", "--ms-penalty", "--ms-penalty-growth",
                                                         "--ms-penalty-max"};
  narx->add_option("--ms-window", n->q.multiple_shooting.window,
                   "oem-ms: samples per window (>= na), each simulated from a free initial output history")
      ->capture_default_str();
  narx->add_option("--ms-penalty", n->q.multiple_shooting.penalty,
                   "oem-ms: weight rho of a continuity residual (window start against the previous window's end) "
                   "against one sample's error, at the start")
      ->capture_default_str();
  narx->add_option("--ms-penalty-growth", n->q.multiple_shooting.penalty_growth,
                   "oem-ms: rho times this after every accepted step (1 = constant)")
      ->capture_default_str();
  narx->add_option("--ms-penalty-max", n->q.multiple_shooting.penalty_max, "oem-ms: rho grows no further")
      ->capture_default_str();
  narx->add_option("--out", n->out, "Model file to write (JSON)");
  narx->add_option("--history", n->history_out,
                   "Write the training history (J per iteration) to this JSON file, {\"history\": [...]}, the form analyze "
                   "--history reads; without it the history goes to stderr");
  narx->footer(
      "Example (the best recipe measured, docs/identification.md):\n  panelbass identify narx --data est.csv --val val.csv "
      "--fs 3000 --na 8 --nb 8 --hidden 17 --train pem,oem-d --optimizer lm --weight-decay 0.01 --evidence-decay all "
      "--pem-min-progress 0.1 --max-iter 200 --seed 1 --out nn.json   (the defaults but --max-iter)\n"
      "  panelbass identify narx --data est.csv --val val.csv --fs 3000 --train pem,oem-ms,oem-d --ms-window 250 "
      "--out nn-ms.json\n"
      "  panelbass identify narx --data more.csv --val val.csv --fs 3000 --start-from nn.json --train oem-d "
      "--max-iter 20 --out nn2.json");
  narx->callback([n, narx, multiple_shooting_flags] {
    IdentifyNarxOptions o = *n;
    if (narx->count("--weight-decay") > 0) o.q.weight_decay = o.weight_decay;
    if (narx->count("--evidence-decay") > 0) o.q.evidence_decay = o.evidence_decay;
    for (const std::string& flag : multiple_shooting_flags) {
      if (narx->count(flag) > 0 && o.train.find("oem-ms") == std::string::npos) {
        throw std::invalid_argument(flag + " applies to the oem-ms stage: add oem-ms to --train (e.g. pem,oem-ms,oem-d)");
      }
    }
    if (!o.start_from.empty()) {
      for (const char* name : {"--na", "--nb", "--nk", "--hidden"}) {
        if (narx->count(name) > 0) {
          throw std::invalid_argument("--start-from takes the model's structure: leave out --na, --nb, --nk and --hidden");
        }
      }
    }
    if (!o.gradient_check && o.out.empty()) throw CLI::RequiredError("--out");
    run_identify_narx(std::move(o));
  });

  register_identify_ss(*identify);
  register_identify_oscillator(*identify);
  register_identify_average(*identify);
  register_identify_mimo(*identify);
}

}  // namespace panelbass::cli
