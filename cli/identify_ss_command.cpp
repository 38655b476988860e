// `panelbass identify ss`: the neural state-space model (SUBNET) from the best linear model.

#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/stop_signals.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "models/linear/linear_identification.h"
#include "models/state_space_nn/ss_initial_state.h"
#include "models/state_space_nn/ss_training.h"
#include "models/state_space_nn/ss_wiener_hammerstein.h"
#include "models/validation/performance.h"

namespace panelbass::cli {
namespace {

struct IdentifySsOptions {
  std::string data, val, out, linear, start_from, history_out, activation = "tanh", initial_state;
  DataOptions columns;
  int nx = 6, nk = -1, hidden = 20, lags = 50, encoder_hidden = 0, poly_degree = 0, poly_states = 0;
  long window = 100, batch = 32, init = 50;
  int epochs = 100, patience = 0, polish_iterations = 0, wh_iterations = 200, wh_candidates = 1;
  long polish_window = 0;
  double max_seconds = 0.0, learning_rate = 1e-3, final_learning_rate = 0.0;
  std::uint64_t seed = 1;
  bool wiener_hammerstein = false, poly_states_only = false, hidden_states_only = false;
};

/// The linear starting model: --linear's file, else OE of order --nx fitted on the same data.
models::LinearModel starting_linear(const IdentifySsOptions& o, const dsp::Record& est, const Eigen::VectorXd& u_val,
                                    const Eigen::VectorXd& y_val) {
  if (!o.linear.empty()) {
    models::LinearModel lin = models::load_linear_model(o.linear);
    if (lin.fs != est.fs) {
      throw std::invalid_argument("--linear " + o.linear + ": identified at " + std::to_string(lin.fs) + " Hz, the data is at " +
                                  std::to_string(est.fs) + " Hz");
    }
    return lin;
  }
  models::LinearIdentificationSpec spec;
  spec.method = models::LinearMethod::oe;
  spec.order = o.nx;
  spec.delay = o.nk;
  spec.init = o.init;
  spec.fs = est.fs;
  std::fprintf(stderr, "identify ss: linear start, OE of order %d\n", o.nx);
  return models::identify_linear(est.columns[0], est.columns[1], u_val, y_val, spec).model;
}

void run_identify_ss(const IdentifySsOptions& o) {
  const dsp::Record est = o.columns.read(o.data);
  const DataOptions::Validation val = o.columns.read_optional_validation(o.val, est.fs);
  const Eigen::VectorXd &u_val = val.u, &y_val = val.y;
  if (o.start_from.empty() && est.columns[0].size() < o.lags + o.window) {
    throw std::invalid_argument(o.data + ": " + std::to_string(est.columns[0].size()) + " samples, --lags + --window = " +
                                std::to_string(o.lags + o.window) + " needed");
  }
  if (o.wiener_hammerstein && o.hidden < 1) {
    throw std::invalid_argument("--wiener-hammerstein needs --hidden >= 1: the tanh nodes of the static nonlinearity");
  }
  if (o.wiener_hammerstein && (o.activation != "tanh" || o.hidden_states_only)) {
    throw std::invalid_argument("--wiener-hammerstein takes neither --activation cubic nor --hidden-states-only: its nodes are tanh nodes of the front filter's output");
  }
  if (o.poly_states > 0 && o.poly_degree == 0) {
    throw std::invalid_argument("--poly-states needs --poly-degree: the monomials it restricts");
  }
  if (o.poly_states > 0 && o.linear.empty() && o.poly_states > o.nx) {
    throw std::invalid_argument("--poly-states " + std::to_string(o.poly_states) + " exceeds --nx " + std::to_string(o.nx) +
                                ": the monomials are of the leading states, at most all of them");
  }
  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };
  models::SsModel start;
  nlohmann::json wh_start = nullptr;
  if (!o.start_from.empty()) {
    const models::AnyModel any = models::load_model(o.start_from);
    const auto* ss = std::get_if<models::SsModel>(&any.model);
    if (ss == nullptr) throw std::invalid_argument("--start-from " + o.start_from + ": expected an ss model, got " + any.kind());
    if (ss->fs != est.fs) throw std::invalid_argument("--start-from " + o.start_from + ": identified at another sample rate");
    start = *ss;
  } else {
    models::SsStructure structure;
    structure.hidden = o.hidden;
    structure.lags = o.lags;
    structure.encoder_hidden = o.encoder_hidden;
    structure.poly_degree = o.poly_degree;
    structure.poly_input = !o.poly_states_only && o.poly_states == 0;
    structure.poly_states = o.poly_states;
    structure.activation = models::ss_activation_from_name(o.activation);
    structure.hidden_input = !o.hidden_states_only;
    const models::LinearModel linear = starting_linear(o, est, u_val, y_val);
    if (o.wiener_hammerstein) {
      const models::SsWienerHammerstein wh =
          models::ss_wiener_hammerstein_start(linear, structure, est.columns[0], est.columns[1], u_val, y_val,
                                                o.wh_iterations, o.seed, o.wh_candidates);
      std::fprintf(stderr,
                   "identify ss: Wiener-Hammerstein start: %d splits, front %d poles and %d zeros (%d states), "
                   "J from rest %.4g %% (linear %.4g %%), after %d Levenberg-Marquardt steps %.4g %% (%d candidates), %.1f s\n",
                   wh.splits, wh.front_poles, wh.front_zeros, wh.front_states, wh.search_j_pct, wh.linear_j_pct,
                   wh.iterations, wh.j_pct, wh.candidates, seconds());
      start = wh.model;
      wh_start = {{"splits", wh.splits},
                  {"front_poles", wh.front_poles},
                  {"front_zeros", wh.front_zeros},
                  {"front_states", wh.front_states},
                  {"search_J_from_rest_pct", wh.search_j_pct},
                  {"J_from_rest_pct", wh.j_pct},
                  {"iterations", wh.iterations},
                  {"candidates", wh.candidates},
                  {"linear_J_from_rest_pct", wh.linear_j_pct}};
    } else {
      start = models::ss_initial_model(linear, structure, est.columns[0], est.columns[1], o.seed);
    }
  }

  // The initial state: the encoder's, or fitted per record against the prior of the start's states (the
  // selection's J is then the fitted one, as the written model's is; the prior is the kept model's in the file).
  const bool fit_initial_state = o.initial_state == "fit" || (o.initial_state.empty() && start.state_prior);
  const std::string initial_state = fit_initial_state ? "fit" : "encoder";
  auto set_prior = [&](models::SsModel& m) {
    m.state_prior.reset();
    if (fit_initial_state) m.state_prior = models::ss_state_prior(m, est.columns[0], est.columns[1], o.init);
  };
  set_prior(start);

  models::SsTrainingOptions options;
  options.window = o.window;
  options.batch = o.batch;
  options.max_epochs = o.epochs;
  options.patience = o.patience;
  options.adam.learning_rate = o.learning_rate;
  options.final_learning_rate = o.final_learning_rate;
  options.init = o.init;
  options.seed = o.seed;
  const StopSignals stop;
  nlohmann::json history = nlohmann::json::array();
  options.progress = [&](const models::SsTrainingRecord& r) {
    std::fprintf(stderr, "identify ss: epoch %d: loss %.4g, J_%s %.4g %%, %.1f s\n", r.epoch, r.loss,
                 u_val.size() ? "val" : "est", r.j_val_pct, seconds());
    history.push_back({{"epoch", r.epoch},
                       {"loss", models::number_or_null(r.loss)},
                       {"J_sel_pct", models::number_or_null(r.j_val_pct)},
                       {"seconds", seconds()}});
    return !stop_requested() && !(o.max_seconds > 0.0 && seconds() >= o.max_seconds);
  };
  models::SsTraining trained = models::train_ss(start, est.columns[0], est.columns[1], u_val, y_val, options);
  const double j_start = trained.history.front().j_val_pct;
  if (o.polish_iterations > 0 && !stop_requested()) {
    models::SsPolishOptions polish;
    polish.window = o.polish_window > 0 ? o.polish_window : o.window;
    polish.iterations = o.polish_iterations;
    polish.init = o.init;
    polish.progress = [&](const models::SsTrainingRecord& r) {
      std::fprintf(stderr, "identify ss: L-BFGS iteration %d: loss %.4g, J_%s %.4g %%, %.1f s\n", r.epoch, r.loss,
                   u_val.size() ? "val" : "est", r.j_val_pct, seconds());
      history.push_back({{"lbfgs_iteration", r.epoch},
                         {"loss", models::number_or_null(r.loss)},
                         {"J_sel_pct", models::number_or_null(r.j_val_pct)},
                         {"seconds", seconds()}});
      return !stop_requested() && !(o.max_seconds > 0.0 && seconds() >= 2.0 * o.max_seconds);
    };
    const models::SsTraining polished = models::polish_ss(trained.model, est.columns[0], est.columns[1], u_val, y_val, polish);
    std::fprintf(stderr, "identify ss: L-BFGS stopped: liblbfgs status %d after %zu iterations\n", polished.status,
                 polished.history.size() - 1);
    trained.model = polished.model;
    trained.j_val_pct = polished.j_val_pct;
    trained.runaway = polished.runaway;
  }
  if (trained.runaway) {
    throw std::runtime_error(
        "identify ss: no model written to " + o.out + ": the free run of every candidate (the start, " +
        std::to_string(trained.history.size() - 1) + " epochs" + (o.polish_iterations > 0 ? " and the L-BFGS iterates" : "") +
        ") left the bound on full-scale noise (the start's |y| = " + std::to_string(trained.runaway->magnitude) + " after " +
        std::to_string(trained.runaway->samples) +
        " samples, scaled units), so no reader would load it. Try fewer states (--nx), a lower --poly-degree, "
        "without --poly-states-only, a lower --lr, or more estimation data");
  }
  if (fit_initial_state && trained.model.theta != start.theta) {
    set_prior(trained.model);
    if (u_val.size()) trained.j_val_pct = models::j_percent(trained.model.simulate(u_val, y_val, o.init), y_val, o.init);
  }
  const double j_est = models::j_percent(trained.model.simulate(est.columns[0], est.columns[1], o.init), est.columns[1], o.init);
  const double j_val = u_val.size() ? trained.j_val_pct : NAN;
  trained.model.meta = {{"data", o.data},
                        {"val", o.val},
                        {"linear", o.linear},
                        {"init", o.init},
                        {"initial_state", initial_state},
                        {"J_est_pct", j_est},
                        {"J_val_pct", models::number_or_null(j_val)},
                        {"start_J_pct", j_start},
                        {"wiener_hammerstein_start", wh_start},
                        {"epochs", static_cast<int>(trained.history.size()) - 1},
                        {"best_epoch", trained.best_epoch},
                        {"seconds", seconds()}};
  models::save_ss_model(o.out, trained.model);
  if (!o.history_out.empty()) models::write_json_file(o.history_out, {{"history", history}});
  print_result({{"J_est_pct", j_est},
                {"J_val_pct", models::number_or_null(j_val)},
                {"start_J_pct", j_start},
                {"initial_state", initial_state},
                {"states", trained.model.structure.states},
                {"params", trained.model.theta.size()},
                {"epochs", static_cast<int>(trained.history.size()) - 1},
                {"best_epoch", trained.best_epoch},
                {"seconds", seconds()},
                {"history_out", o.history_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.history_out)},
                {"out", o.out}});
}

}  // namespace

void register_identify_ss(CLI::App& identify) {
  auto o = std::make_shared<IdentifySsOptions>();
  CLI::App* cmd = identify.add_subcommand(
      "ss", "Neural state-space model (SUBNET): linear state space plus tanh networks, encoder initial state");
  cmd->add_option("--data", o->data, "Estimation data, .csv or .wav")->required();
  cmd->add_option("--val", o->val, "Validation data (selection and J_val)");
  o->columns.add_to(cmd);
  cmd->add_option("--linear", o->linear, "Linear model file to start from (default: OE of order --nx on --data)");
  cmd->add_option("--nx", o->nx, "States: the order of the OE start (without --linear)")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_option("--nk", o->nk, "Input delay of the OE start (-1: estimated)")->check(CLI::Range(-1, 1000))->capture_default_str();
  cmd->add_option("--hidden", o->hidden, "Tanh nodes of the state/output network (0: none, with --poly-degree)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  cmd->add_option("--poly-degree", o->poly_degree,
                  "Add PNLSS's polynomial: monomials of [x; u] of degree 2 to this (0: none, else 2-5)")
      ->check(CLI::IsMember({0, 2, 3, 4, 5}))
      ->capture_default_str();
  cmd->add_option("--activation", o->activation,
                  "The nodes' activation: tanh, or cubic (a³: with its bias each node is a cubic of one direction of "
                  "[x; u] fed back, a nonlinear-feedback / LFR model)")
      ->check(CLI::IsMember({"tanh", "cubic"}))
      ->capture_default_str();
  cmd->add_flag("--hidden-states-only", o->hidden_states_only,
               "The nodes read the states alone, not the input (with --activation cubic: a cubic of the states "
               "fed back, a Duffing oscillator's form)");
  cmd->add_flag("--poly-states-only", o->poly_states_only,
               "The polynomial's monomials of the states alone, none of the input (PNLSS's states-only form)");
  cmd->add_option("--poly-states", o->poly_states,
                  "The polynomial's monomials of the first N states alone (implies --poly-states-only; 0: all states). "
                  "The start is balanced, its states in descending Hankel singular value: the leading ones carry the "
                  "dominant dynamics, the others stay linear")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_flag("--wiener-hammerstein", o->wiener_hammerstein,
               "Start from a Wiener-Hammerstein model: the linear start's poles and zeros split between two filters, "
               "--hidden tanh nodes between them (the split of the lowest J_val kept)");
  cmd->add_option("--wh-iter", o->wh_iterations,
                  "Levenberg-Marquardt iterations refining the Wiener-Hammerstein start's blocks jointly (0: none)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_option("--wh-candidates", o->wh_candidates,
                  "Splits of the Wiener-Hammerstein search refined 20 steps each before the best one is kept")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--lags", o->lags, "Past inputs and outputs the encoder reads")->check(CLI::Range(1, 1000))->capture_default_str();
  cmd->add_option("--encoder-hidden", o->encoder_hidden, "Tanh nodes of the encoder (0: affine)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  cmd->add_option("--window", o->window, "Samples simulated per training window (T)")->check(CLI::Range(1L, 100000L))->capture_default_str();
  cmd->add_option("--batch", o->batch, "Windows per Adam step")->check(CLI::Range(1L, 100000L))->capture_default_str();
  cmd->add_option("--epochs", o->epochs, "Most epochs (each draws N/T windows)")->check(CLI::Range(0, 1000000))->capture_default_str();
  cmd->add_option("--max-seconds", o->max_seconds, "Stop Adam after this many seconds, the L-BFGS polish at twice that (0: no limit)")->check(CLI::Range(0.0, 1e7))->capture_default_str();
  cmd->add_option("--patience", o->patience, "Epochs without a better J before stopping (0: never)")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--lr", o->learning_rate, "Adam's learning rate")->check(CLI::Range(1e-9, 1.0))->capture_default_str();
  cmd->add_option("--lr-final", o->final_learning_rate, "Learning rate reached at --epochs, geometric decay (0: constant)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--start-from", o->start_from, "An ss model file to train on from where it is (its sizes kept)");
  cmd->add_option("--polish-iter", o->polish_iterations, "L-BFGS iterations on the full batch after Adam (0: none)")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--polish-window", o->polish_window, "Window of the L-BFGS polish (0: --window)")
      ->check(CLI::Range(0L, 10000000L))
      ->capture_default_str();
  cmd->add_option("--initial-state", o->initial_state,
                  "How a free run's state starts from the --init measured samples: encoder (SUBNET's, an affine map of "
                  "them), or fit (x(0) fitted through the model to those outputs against the prior of its states along "
                  "--data; written into the model, so validate and every reader use it). Default: the encoder, or "
                  "--start-from's own. With --start-from M --epochs 0 it converts M")
      ->check(CLI::IsMember({"encoder", "fit"}));
  cmd->add_option("--init", o->init, "Measured samples that set the state before J (the J reported and selected on)")
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the initial weights and the window draws")->capture_default_str();
  cmd->add_option("--history-out", o->history_out, "Write the J of every epoch (JSON) here");
  cmd->add_option("--out", o->out, "Model file to write")->required();
  cmd->footer(
      "Example:\n  panelbass identify ss --data est.csv --val val.csv --fs 51200 --nx 6 --hidden 20 --lags 50 "
      "--window 100 --epochs 200 --out ss.json\n"
      "  panelbass identify ss --data est.csv --val val.csv --fs 610.35 --nx 2 --hidden 0 --poly-degree 3 --out pnlss.json\n"
      "  panelbass identify ss --data est.csv --val val.csv --fs 610.35 --nx 4 --hidden 0 --poly-degree 3 --poly-states 2 "
      "--out pnlss4.json\n"
      "  panelbass identify ss --data est.csv --val val.csv --fs 610.35 --nx 2 --hidden 2 --activation cubic "
      "--hidden-states-only --out lfr.json\n"
      "  panelbass identify ss --data est.csv --val val.csv --fs 51200 --nx 6 --hidden 20 --lags 50 --wiener-hammerstein "
      "--epochs 0 --polish-iter 2000 --polish-window 400 --out wh.json\n"
      "  panelbass identify ss --data est.csv --val val.csv --fs 51200 --start-from wh.json --epochs 0 --initial-state fit "
      "--out wh-fit.json");
  cmd->callback([o] { run_identify_ss(*o); });
}

}  // namespace panelbass::cli
