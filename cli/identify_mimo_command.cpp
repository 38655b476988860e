// `panelbass identify mimo`: a multi-input multi-output linear state space from periodic steady-state
// records (FIR on circular regressors → Kung's realisation → Levenberg–Marquardt on the simulation error).

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "dsp/periodic_record.h"
#include "models/linear/mimo_model.h"
#include "usecases/identify_mimo.h"

namespace panelbass::cli {
namespace {

// The options of `identify mimo`; the defaults are the request's (usecases::IdentifyMimoRequest).
struct IdentifyMimoOptions {
  std::vector<std::string> data;
  std::string out;
  usecases::IdentifyMimoRequest q;  ///< the flags' values (the records read by run_identify_mimo)
};

void run_identify_mimo(IdentifyMimoOptions o) {
  usecases::IdentifyMimoRequest& q = o.q;
  dsp::PeriodicColumns columns;
  columns.inputs = q.inputs;
  columns.outputs = q.outputs;
  for (const std::string& path : o.data) {
    q.records.push_back(dsp::read_periodic_csv(path, columns, q.fs));
    q.record_names.push_back(path);
    const dsp::PeriodicRecord& record = q.records.back();
    std::fprintf(stderr, "identify mimo: %s: %zu realizations x %zu periods x %ld samples\n", path.c_str(),
                 record.realizations(), record.periods(), static_cast<long>(record.period));
  }
  StoppableBarProgress progress("identify mimo");
  // A record that does not pool with the first is the fault of the files --data names (exit 1).
  const usecases::IdentifyMimoReport report =
      run_use_case([&] { return usecases::identify_mimo(q, progress); },
                   {{{"record", "--data"}, {"max_iterations", "--max-iter"}}, {{"record", "--data"}}});
  print_warnings("identify mimo", report.warnings);
  models::save_mimo_model(o.out, report.model);
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  print_result(result);
}

}  // namespace

void register_identify_mimo(CLI::App& identify) {
  auto o = std::make_shared<IdentifyMimoOptions>();
  CLI::App* cmd = identify.add_subcommand(
      "mimo", "Multi-input multi-output linear state space from periodic steady-state data (FIR, Kung, output error)");
  cmd->add_option("--data", o->data,
                  "Periodic CSV (columns realization, period, the inputs and the outputs); repeat to pool several files")
      ->required();
  cmd->add_option("--fs", o->q.fs, "Sample rate, Hz")->required()->check(CLI::PositiveNumber);
  cmd->add_option("--inputs", o->q.inputs, "Input columns")->delimiter(',')->capture_default_str();
  cmd->add_option("--outputs", o->q.outputs, "Output columns")->delimiter(',')->capture_default_str();
  cmd->add_option("--order", o->q.order, "States (0: at the largest gap of the Hankel singular values)")
      ->capture_default_str();
  cmd->add_option("--taps", o->q.taps, "Markov parameters estimated before Kung's realisation")
      ->capture_default_str();
  cmd->add_option("--ridge", o->q.ridge, "Ridge of the FIR's normal equations, relative to their mean diagonal")
      ->capture_default_str();
  cmd->add_option("--max-iter", o->q.max_iterations, "Levenberg-Marquardt iterations at most (0: Kung's model)")
      ->capture_default_str();
  cmd->add_option("--val-realizations", o->q.val_realizations,
                  "Realizations at the end of every --data file held out to select the iterate (validation J)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write")->required();
  cmd->footer(
      "Example:\n  zcat fsm_100mV_train.csv.gz > train.csv\n"
      "  panelbass identify mimo --data train.csv --fs 6400 --order 52 --taps 150 --max-iter 40 --out fsm.json\n"
      "  panelbass validate --model fsm.json --data test.csv --init 100 --warmup 1000");
  cmd->callback([o] { run_identify_mimo(*o); });
}

}  // namespace panelbass::cli
