// `panelbass identify average`: averaging restarts — the mean of ss models' free runs as one ss model, its
// members chosen by validation J.

#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/kinds/model_file.h"
#include "usecases/identify_average.h"

namespace panelbass::cli {
namespace {

// The options of `identify average`; the defaults are the request's (usecases::IdentifyAverageRequest).
struct IdentifyAverageOptions {
  std::vector<std::string> models;
  std::string val, out;
  DataOptions columns;
  long init = usecases::IdentifyAverageRequest{}.init;
};

/// The ss model in `path`; an error naming the file and its kind otherwise.
models::SsModel load_ss(const std::string& path) {
  const models::AnyModel any = models::load_model(path);
  if (const auto* ss = std::get_if<models::SsModel>(&any.model)) return *ss;
  throw std::invalid_argument("--models " + path + ": a " + any.kind() + " model; identify average takes ss models (identify ss)");
}

void run_identify_average(const IdentifyAverageOptions& o) {
  usecases::IdentifyAverageRequest q;
  for (const std::string& path : o.models) q.models.push_back(load_ss(path));
  q.model_names = o.models;
  q.init = o.init;
  if (!o.val.empty()) {
    const dsp::Record val = o.columns.read_at_model_rate(o.val, q.models[0].fs);
    q.u_val = val.columns[0];
    q.y_val = val.columns[1];
    q.val_name = o.val;
  }
  BarProgress progress("identify average");
  // A model that cannot sit beside the others is the fault of the files --models names (exit 1).
  const usecases::IdentifyAverageReport report = run_use_case(
      [&] { return usecases::identify_average(q, progress); },
      {{{"record", "--val"}}, {{"models", "--models"}, {"record", o.val}}});
  print_warnings("identify average", report.warnings);
  models::save_ss_model(o.out, report.model);
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  print_result(result);
}

}  // namespace

void register_identify_average(CLI::App& identify) {
  auto o = std::make_shared<IdentifyAverageOptions>();
  CLI::App* cmd = identify.add_subcommand(
      "average", "Averaging restarts: ss models' mean output as one ss model, members chosen by validation J");
  cmd->add_option("--models", o->models, "ss model files trained on the same estimation data (identify ss)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--val", o->val,
                  "Validation data: members added one by one, each time the one that leaves the mean of the lowest J; the first ones up to the lowest J are kept (without it: all)");
  o->columns.add_to(cmd);
  cmd->add_option("--init", o->init, "Measured samples that set the state before J (the J the models report)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write (an ss model: the members' states side by side)")->required();
  cmd->footer(
      "Example:\n  panelbass identify average --models wh10.json wh15.json wh20.json --val val.csv --fs 51200 --out avg.json\n"
      "  panelbass validate --model avg.json --data test.csv --fs 51200 --init 50");
  cmd->callback([o] { run_identify_average(*o); });
}

}  // namespace panelbass::cli
