// `panelbass identify ss`: the neural state-space model (SUBNET) from the best linear model.

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "usecases/identify_ss.h"

namespace panelbass::cli {
namespace {

// The options of `identify ss`; the defaults are the request's (usecases::IdentifySsRequest).
struct IdentifySsOptions {
  std::string data, val, out, linear, start_from, history_out;
  DataOptions columns;
  usecases::IdentifySsRequest q;  ///< the flags' values (records and models filled in by run_identify_ss)
};

void run_identify_ss(IdentifySsOptions o) {
  usecases::IdentifySsRequest& q = o.q;
  o.columns.read_into(q, o.data, o.val);
  if (!o.linear.empty()) {
    q.linear = models::load_linear_model(o.linear);
    q.linear_name = o.linear;
  }
  if (!o.start_from.empty()) {
    const models::AnyModel any = models::load_model(o.start_from);
    const auto* ss = std::get_if<models::SsModel>(&any.model);
    if (ss == nullptr) throw std::invalid_argument("--start-from " + o.start_from + ": expected an ss model, got " + any.kind());
    q.start_from = *ss;
    q.start_from_name = o.start_from;
  }
  StoppableBarProgress progress("identify ss");
  usecases::IdentifySsReport report;
  try {
    report = run_use_case([&] { return usecases::identify_ss(q, progress); },
                          {{{"record", "--data"}, {"learning_rate", "--lr"}, {"final_learning_rate", "--lr-final"},
                            {"polish_iterations", "--polish-iter"}, {"wh_iterations", "--wh-iter"}},
                           {{"record", o.data}, {"linear", o.linear}, {"start_from", o.start_from}}});
  } catch (const CLI::Error&) {
    throw;  // a refused flag (a usage error)
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("identify ss: no model written to " + o.out + ": " + e.what());
  }
  print_warnings("identify ss", report.warnings);
  models::save_ss_model(o.out, report.model);
  if (!o.history_out.empty()) models::write_json_file(o.history_out, {{"history", report.history}});
  nlohmann::json result = report.summary;
  result["history_out"] = o.history_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.history_out);
  result["out"] = o.out;
  print_result(result);
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
  cmd->add_option("--nx", o->q.nx, "States: the order of the OE start (without --linear)")->capture_default_str();
  cmd->add_option("--nk", o->q.nk, "Input delay of the OE start (-1: estimated)")->capture_default_str();
  cmd->add_option("--hidden", o->q.hidden, "Tanh nodes of the state/output network (0: none, with --poly-degree)")
      ->capture_default_str();
  cmd->add_option("--poly-degree", o->q.poly_degree,
                  "Add PNLSS's polynomial: monomials of [x; u] of degree 2 to this (0: none, else 2-5)")
      ->capture_default_str();
  cmd->add_option("--activation", o->q.activation,
                  "The nodes' activation: tanh, or cubic (a³: with its bias each node is a cubic of one direction of "
                  "[x; u] fed back, a nonlinear-feedback / LFR model)")
      ->capture_default_str();
  cmd->add_flag("--hidden-states-only", o->q.hidden_states_only,
               "The nodes read the states alone, not the input (with --activation cubic: a cubic of the states "
               "fed back, a Duffing oscillator's form)");
  cmd->add_flag("--poly-states-only", o->q.poly_states_only,
               "The polynomial's monomials of the states alone, none of the input (PNLSS's states-only form)");
  cmd->add_option("--poly-states", o->q.poly_states,
                  "The polynomial's monomials of the first N states alone (implies --poly-states-only; 0: all states). "
                  "The start is balanced, its states in descending Hankel singular value: the leading ones carry the "
                  "dominant dynamics, the others stay linear")
      ->capture_default_str();
  cmd->add_flag("--wiener-hammerstein", o->q.wiener_hammerstein,
               "Start from a Wiener-Hammerstein model: the linear start's poles and zeros split between two filters, "
               "--hidden tanh nodes between them (the split of the lowest J_val kept)");
  cmd->add_option("--wh-iter", o->q.wh_iterations,
                  "Levenberg-Marquardt iterations refining the Wiener-Hammerstein start's blocks jointly (0: none)")
      ->capture_default_str();
  cmd->add_option("--wh-candidates", o->q.wh_candidates,
                  "Splits of the Wiener-Hammerstein search refined 20 steps each before the best one is kept")
      ->capture_default_str();
  cmd->add_option("--lags", o->q.lags, "Past inputs and outputs the encoder reads")->capture_default_str();
  cmd->add_option("--encoder-hidden", o->q.encoder_hidden, "Tanh nodes of the encoder (0: affine)")
      ->capture_default_str();
  cmd->add_option("--window", o->q.window, "Samples simulated per training window (T)")->capture_default_str();
  cmd->add_option("--batch", o->q.batch, "Windows per Adam step")->capture_default_str();
  cmd->add_option("--epochs", o->q.epochs, "Most epochs (each draws N/T windows)")->capture_default_str();
  cmd->add_option("--max-seconds", o->q.max_seconds, "Stop Adam after this many seconds, the L-BFGS polish at twice that (0: no limit)")->capture_default_str();
  cmd->add_option("--patience", o->q.patience, "Epochs without a better J before stopping (0: never)")
      ->capture_default_str();
  cmd->add_option("--lr", o->q.learning_rate, "Adam's learning rate")->capture_default_str();
  cmd->add_option("--lr-final", o->q.final_learning_rate, "Learning rate reached at --epochs, geometric decay (0: constant)")
      ->capture_default_str();
  cmd->add_option("--start-from", o->start_from, "An ss model file to train on from where it is (its sizes kept)");
  cmd->add_option("--polish-iter", o->q.polish_iterations, "L-BFGS iterations on the full batch after Adam (0: none)")
      ->capture_default_str();
  cmd->add_option("--polish-window", o->q.polish_window, "Window of the L-BFGS polish (0: --window)")
      ->capture_default_str();
  cmd->add_option("--initial-state", o->q.initial_state,
                  "How a free run's state starts from the --init measured samples: encoder (SUBNET's, an affine map of "
                  "them), or fit (x(0) fitted through the model to those outputs against the prior of its states along "
                  "--data; written into the model, so validate and every reader use it). Default: the encoder, or "
                  "--start-from's own. With --start-from M --epochs 0 it converts M");
  cmd->add_option("--init", o->q.init, "Measured samples that set the state before J (the J reported and selected on)")
      ->capture_default_str();
  cmd->add_option("--seed", o->q.seed, "Seed of the initial weights and the window draws")->capture_default_str();
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
