#include <cmath>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "models/kinds/model_file.h"
#include "models/validation/performance.h"

namespace panelbass::cli {
namespace {

struct ValidateOptions {
  std::string model, data;
  DataOptions columns;
  long init = 0;
};

void run_validate(const ValidateOptions& o) {
  const models::AnyModel model = models::load_model(o.model);
  const dsp::Record data = o.columns.read_at_model_rate(o.data, model.fs());
  const Eigen::VectorXd& u = data.columns[0];
  const Eigen::VectorXd& y = data.columns[1];
  if (o.init >= u.size()) throw std::invalid_argument("--init " + std::to_string(o.init) + " is not shorter than the data");
  const Eigen::VectorXd y_sim = model.simulate(u, y, o.init);
  const Eigen::VectorXd y_pred = model.predict(u, y);
  const Eigen::Index n = u.size() - o.init;
  const double rmse = std::sqrt((y_sim - y).tail(n).squaredNorm() / static_cast<double>(n));
  print_result({{"J_sim_pct", models::j_percent(y_sim, y, o.init)},
                {"J_pred_pct", models::j_percent(y_pred, y, o.init)},
                {"rmse", rmse},
                {"samples", n},
                {"kind", model.kind()},
                {"init", o.init},
                {"model", o.model},
                {"data", o.data}});
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
  cmd->footer("Example:\n  panelbass validate --model lin.json --data test.csv --fs 610.3515625 --init 50");
  cmd->callback([o] { run_validate(*o); });
}

}  // namespace panelbass::cli
