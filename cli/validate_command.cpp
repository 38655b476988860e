#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <variant>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "dsp/data_file.h"
#include "dsp/periodic_record.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "models/linear/mimo_model.h"
#include "models/validation/performance.h"
#include "models/validation/periodic_rmse.h"
#include "usecases/validate_model.h"

namespace panelbass::cli {
namespace {

struct ValidateOptions {
  std::string model, data;
  std::string sim_out;  ///< where the record with the free-run and one-step outputs goes (empty: nowhere)
  DataOptions columns;
  long init = 0;
  long warmup = 1000;  ///< a MIMO model's steady-state warm-up, samples
};

/// A MIMO model on a periodic record: per realisation its periods one after the other, continued from the
/// periodic steady state (the last --warmup samples played first), scored by the FSM benchmark's protocol.
void run_validate_mimo(const ValidateOptions& o) {
  const models::MimoModel model = models::load_mimo_model(o.model);
  if (o.columns.fs > 0.0 && o.columns.fs != model.fs) {
    throw std::invalid_argument("--fs " + std::to_string(o.columns.fs) + ": " + o.model + " was identified at " +
                                std::to_string(model.fs) + " Hz");
  }
  if (!o.sim_out.empty()) throw std::invalid_argument("--sim-out: not written for a mimo model");
  dsp::PeriodicColumns columns;
  columns.inputs = model.inputs;
  columns.outputs = model.outputs;
  const dsp::PeriodicRecord data = dsp::read_periodic_csv(o.data, columns, model.fs);
  if (o.init >= data.period) {
    throw std::invalid_argument("--init " + std::to_string(o.init) + " is not shorter than a period (" +
                                std::to_string(data.period) + " samples)");
  }
  std::vector<Eigen::MatrixXd> simulated, measured;
  for (std::size_t r = 0; r < data.realizations(); ++r) {
    Eigen::MatrixXd u(data.period * static_cast<Eigen::Index>(data.periods()), model.ss.inputs());
    Eigen::MatrixXd y(u.rows(), model.ss.outputs());
    for (std::size_t q = 0; q < data.periods(); ++q) {
      u.middleRows(static_cast<Eigen::Index>(q) * data.period, data.period) = data.u[r][q];
      y.middleRows(static_cast<Eigen::Index>(q) * data.period, data.period) = data.y[r][q];
    }
    simulated.push_back(models::simulate_after_warmup(model.ss, u, o.warmup));
    measured.push_back(std::move(y));
  }
  const models::PeriodicScore score = models::periodic_score(simulated, measured, data.period, o.init);
  nlohmann::json per_output = nlohmann::json::object();
  for (std::size_t i = 0; i < model.outputs.size(); ++i) per_output[model.outputs[i]] = score.rmse[static_cast<Eigen::Index>(i)];
  print_result({{"J_sim_pct", score.j_pct},
                {"rmse", score.mean_rmse},
                {"rmse_per_output", per_output},
                {"realizations", data.realizations()},
                {"periods", data.periods()},
                {"period", data.period},
                {"kind", "mimo"},
                {"init", o.init},
                {"warmup", o.warmup},
                {"model", o.model},
                {"data", o.data}});
}

void run_validate(const ValidateOptions& o) {
  if (const nlohmann::json file = models::read_json_file(o.model); file.is_object() && file.value("kind", "") == "mimo") {
    run_validate_mimo(o);
    return;
  }
  if (!o.sim_out.empty()) dsp::check_writable_data_file(o.sim_out);
  usecases::ValidateRequest q;
  q.model = models::read_json_file(o.model);
  q.model_name = o.model;
  const double model_fs = models::rate_of(models::read_json_file_as(o.model, models::load_checked_model));
  const dsp::Record data = o.columns.read_at_model_rate(o.data, model_fs);
  q.u = data.columns[0];
  q.y = data.columns[1];
  q.init = o.init;
  usecases::SilentProgress quiet;
  const usecases::ValidateReport report = run_use_case([&] { return usecases::validate_model(q, quiet); });
  if (const auto& note = report.summary.at("J_pred_note"); note.is_string()) {
    std::fprintf(stderr, "validate: %s\n", note.get<std::string>().c_str());
  }
  if (!o.sim_out.empty()) {
    dsp::Record out;
    out.fs = data.fs;
    out.add("u", q.u);
    out.add("y", q.y);
    out.add("y_sim", report.y_sim);
    out.add("y_pred", report.y_pred);
    dsp::write_data_file(o.sim_out, out);
  }
  nlohmann::json result = report.summary;
  result["data"] = o.data;
  result["sim_out"] = o.sim_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.sim_out);
  print_result(result);
}

}  // namespace

void register_validate(CLI::App& app) {
  auto o = std::make_shared<ValidateOptions>();
  CLI::App* cmd = app.add_subcommand("validate", "Judge a model on data by free-run simulation (J, [2A]) and prediction");
  cmd->add_option("--model", o->model, "Model file (JSON)")->required();
  cmd->add_option("--data", o->data, "Data, .csv or .wav")->required();
  o->columns.add_to(cmd);
  cmd->add_option("--init", o->init, "Measured outputs given to the model to set its state, then free run")
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--warmup", o->warmup,
                  "mimo models: samples of the periodic input played before each realization (its last ones) to reach "
                  "the steady state")
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--sim-out", o->sim_out,
                  "Write the record judged, .csv or .wav: columns u, y, y_sim (the free run; the first --init samples "
                  "are the measured outputs that set the state) and y_pred (one step ahead), at the model's rate");
  cmd->footer(
      "Example:\n  panelbass validate --model lin.json --data test.csv --fs 610.3515625 --init 50\n"
      "  panelbass validate --model nn.json --data val.csv --init 50 --sim-out nn-val.csv\n"
      "  panelbass validate --model fsm.json --data fsm_100mV_test.csv --init 100 --warmup 1000   (a mimo model: "
      "RMSE per output, averaged over realizations and periods)");
  cmd->callback([o] { run_validate(*o); });
}

}  // namespace panelbass::cli
