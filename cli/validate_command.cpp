#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <variant>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "dsp/data_file.h"
#include "models/kinds/model_file.h"
#include "models/validation/performance.h"

namespace panelbass::cli {
namespace {

struct ValidateOptions {
  std::string model, data;
  std::string sim_out;  ///< where the record with the free-run and one-step outputs goes (empty: nowhere)
  DataOptions columns;
  long init = 0;
};

/// Why a one-step prediction J can be worse than the simulation J, for `model`: its predictor feeds measured
/// outputs through a noise model it never had (both kinds are fitted for simulation, output error).
std::string prediction_note(const models::AnyModel& model) {
  if (const auto* lm = std::get_if<models::LinearModel>(&model.model)) {
    char gain[64];  // A(q) = 1 + a1 q^-1 + ..., a_1..a_na stored
    std::snprintf(gain, sizeof gain, "%.3g", 1.0 + lm->tf.a.squaredNorm());
    return "J_pred is worse than J_sim because this output-error model has no noise model: its one-step predictor "
           "y(k) = -a1*y(k-1) - ... + B(q)u(k) reads the measured, noisy outputs, so its error is A(q) times the "
           "simulation error, and A(q) multiplies white noise's power by 1 + sum(a_i^2) = " +
           std::string(gain) + ". Judge it by J_sim; J_pred fits a model fitted for prediction (ARX, PEM).";
  }
  return "J_pred is worse than J_sim because the model was trained for simulation (output error): its one-step predictor "
         "feeds the measured, noisy outputs into lags trained on its own noise-free outputs. Judge it by J_sim; J_pred "
         "fits a model trained for prediction (PEM).";
}

void run_validate(const ValidateOptions& o) {
  if (!o.sim_out.empty()) dsp::check_writable_data_file(o.sim_out);
  const models::AnyModel model = models::load_model(o.model);
  const dsp::Record data = o.columns.read_at_model_rate(o.data, model.fs());
  const Eigen::VectorXd& u = data.columns[0];
  const Eigen::VectorXd& y = data.columns[1];
  if (o.init >= u.size()) throw std::invalid_argument("--init " + std::to_string(o.init) + " is not shorter than the data");
  const Eigen::VectorXd y_sim = model.simulate(u, y, o.init);
  const Eigen::VectorXd y_pred = model.predict(u, y);
  const Eigen::Index n = u.size() - o.init;
  const double rmse = std::sqrt((y_sim - y).tail(n).squaredNorm() / static_cast<double>(n));
  const double j_sim = models::j_percent(y_sim, y, o.init), j_pred = models::j_percent(y_pred, y, o.init);
  const std::string note = j_pred > j_sim ? prediction_note(model) : "";
  if (!note.empty()) std::fprintf(stderr, "validate: %s\n", note.c_str());
  if (!o.sim_out.empty()) {
    dsp::Record out;
    out.fs = data.fs;
    out.add("u", u);
    out.add("y", y);
    out.add("y_sim", y_sim);
    out.add("y_pred", y_pred);
    dsp::write_data_file(o.sim_out, out);
  }
  print_result({{"J_sim_pct", j_sim},
                {"J_pred_pct", j_pred},
                {"J_pred_note", note.empty() ? nlohmann::json(nullptr) : nlohmann::json(note)},
                {"rmse", rmse},
                {"samples", n},
                {"kind", model.kind()},
                {"init", o.init},
                {"model", o.model},
                {"data", o.data},
                {"sim_out", o.sim_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.sim_out)}});
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
  cmd->add_option("--sim-out", o->sim_out,
                  "Write the record judged, .csv or .wav: columns u, y, y_sim (the free run; the first --init samples "
                  "are the measured outputs that set the state) and y_pred (one step ahead), at the model's rate");
  cmd->footer(
      "Example:\n  panelbass validate --model lin.json --data test.csv --fs 610.3515625 --init 50\n"
      "  panelbass validate --model nn.json --data val.csv --init 50 --sim-out nn-val.csv");
  cmd->callback([o] { run_validate(*o); });
}

}  // namespace panelbass::cli
