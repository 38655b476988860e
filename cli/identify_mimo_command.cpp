// `panelbass identify mimo`: a multi-input multi-output linear state space from periodic steady-state
// records (FIR on circular regressors → Kung's realisation → Levenberg–Marquardt on the simulation error).

#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/stop_signals.h"
#include "dsp/periodic_record.h"
#include "models/io/json_fields.h"
#include "models/linear/mimo_identification.h"
#include "models/linear/mimo_model.h"

namespace panelbass::cli {
namespace {

struct IdentifyMimoOptions {
  std::vector<std::string> data;
  std::string out;
  std::vector<std::string> inputs{"u1", "u2", "u3"}, outputs{"y1", "y2", "y3"};
  double fs = 0.0;
  int order = 0, max_iterations = 100;
  long taps = 150, val_realizations = 1;
  double ridge = 1e-6;
};

void run_identify_mimo(const IdentifyMimoOptions& o) {
  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };
  dsp::PeriodicColumns columns;
  columns.inputs = o.inputs;
  columns.outputs = o.outputs;
  std::vector<Eigen::MatrixXd> u_est, y_est, u_val, y_val;
  Eigen::Index period = 0;
  for (const std::string& path : o.data) {
    const dsp::PeriodicRecord record = dsp::read_periodic_csv(path, columns, o.fs);
    if (period != 0 && record.period != period) {
      throw std::invalid_argument(path + ": periods of " + std::to_string(record.period) + " samples, the first --data has " +
                                  std::to_string(period));
    }
    period = record.period;
    const auto held = static_cast<std::size_t>(o.val_realizations);
    if (held >= record.realizations()) {
      throw std::invalid_argument(path + ": " + std::to_string(record.realizations()) + " realizations; --val-realizations " +
                                  std::to_string(held) + " leaves none to estimate on");
    }
    for (std::size_t r = 0; r < record.realizations(); ++r) {
      const bool validation = r >= record.realizations() - held;
      (validation ? u_val : u_est).push_back(record.mean_input(r));
      (validation ? y_val : y_est).push_back(record.mean_output(r));
    }
    std::fprintf(stderr, "identify mimo: %s: %zu realizations x %zu periods x %ld samples, the last %zu held out\n",
                 path.c_str(), record.realizations(), record.periods(), static_cast<long>(record.period), held);
  }
  models::MimoIdentificationSpec spec;
  spec.order = o.order;
  spec.taps = o.taps;
  spec.ridge = o.ridge;
  spec.max_iterations = o.max_iterations;
  const StopSignals stop;
  nlohmann::json history = nlohmann::json::array();
  spec.progress = [&](const models::MimoRefinementRecord& r) {
    std::fprintf(stderr, "identify mimo: iteration %d: J_est %.5g %%, J_%s %.5g %%, lambda %.3g, %.1f s\n", r.iteration,
                 r.j_est_pct, u_val.empty() ? "est" : "val", r.j_val_pct, r.lambda, seconds());
    history.push_back({{"iteration", r.iteration}, {"J_est_pct", r.j_est_pct}, {"J_val_pct", r.j_val_pct}});
    return !stop_requested();
  };
  const models::MimoIdentification id = models::identify_mimo(u_est, y_est, u_val, y_val, spec);

  models::MimoModel model;
  model.ss = id.model;
  model.fs = o.fs;
  model.inputs = o.inputs;
  model.outputs = o.outputs;
  model.meta = {{"method", "fir-kung-oe"},
                {"data", o.data},
                {"taps", o.taps},
                {"ridge", o.ridge},
                {"val_realizations", o.val_realizations},
                {"J_est_pct", id.refinement.j_est_pct},
                {"J_val_pct", id.refinement.j_val_pct},
                {"kung_J_val_pct", id.kung_j_val_pct},
                {"best_iteration", id.refinement.best_iteration}};
  models::save_mimo_model(o.out, model);
  const Eigen::Index shown = std::min<Eigen::Index>(id.hankel_singular_values.size(), 60);
  print_result({{"order", id.order},
                {"inputs", o.inputs.size()},
                {"outputs", o.outputs.size()},
                {"J_est_pct", id.refinement.j_est_pct},
                {"J_val_pct", id.refinement.j_val_pct},
                {"kung_J_est_pct", id.kung_j_est_pct},
                {"kung_J_val_pct", id.kung_j_val_pct},
                {"iterations", id.refinement.iterations},
                {"best_iteration", id.refinement.best_iteration},
                {"hankel_singular_values", models::to_array(id.hankel_singular_values.head(shown))},
                {"history", history},
                {"seconds", seconds()},
                {"out", o.out}});
}

}  // namespace

void register_identify_mimo(CLI::App& identify) {
  auto o = std::make_shared<IdentifyMimoOptions>();
  CLI::App* cmd = identify.add_subcommand(
      "mimo", "Multi-input multi-output linear state space from periodic steady-state data (FIR, Kung, output error)");
  cmd->add_option("--data", o->data,
                  "Periodic CSV (columns realization, period, the inputs and the outputs); repeat to pool several files")
      ->required();
  cmd->add_option("--fs", o->fs, "Sample rate, Hz")->required()->check(CLI::PositiveNumber);
  cmd->add_option("--inputs", o->inputs, "Input columns")->delimiter(',')->capture_default_str();
  cmd->add_option("--outputs", o->outputs, "Output columns")->delimiter(',')->capture_default_str();
  cmd->add_option("--order", o->order, "States (0: at the largest gap of the Hankel singular values)")
      ->check(CLI::Range(0, 200))
      ->capture_default_str();
  cmd->add_option("--taps", o->taps, "Markov parameters estimated before Kung's realisation")
      ->check(CLI::Range(3L, 100000L))
      ->capture_default_str();
  cmd->add_option("--ridge", o->ridge, "Ridge of the FIR's normal equations, relative to their mean diagonal")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--max-iter", o->max_iterations, "Levenberg-Marquardt iterations at most (0: Kung's model)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_option("--val-realizations", o->val_realizations,
                  "Realizations at the end of every --data file held out to select the iterate (validation J)")
      ->check(CLI::Range(0L, 1000L))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write")->required();
  cmd->footer(
      "Example:\n  zcat fsm_100mV_train.csv.gz > train.csv\n"
      "  panelbass identify mimo --data train.csv --fs 6400 --order 52 --taps 150 --max-iter 40 --out fsm.json\n"
      "  panelbass validate --model fsm.json --data test.csv --init 100 --warmup 1000");
  cmd->callback([o] { run_identify_mimo(*o); });
}

}  // namespace panelbass::cli
