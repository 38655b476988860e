// `panelbass identify average`: averaging restarts — the mean of ss models' free runs as one ss model, its
// members chosen by validation J.

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/state_space_nn/ss_average.h"
#include "models/validation/performance.h"

namespace panelbass::cli {
namespace {

struct IdentifyAverageOptions {
  std::vector<std::string> models;
  std::string val, out;
  DataOptions columns;
  long init = 50;
};

/// The ss model in `path`, started by its encoder as the written average will be (a fitted initial state does
/// not carry over: the members' priors do not combine); an error naming the file and its kind otherwise.
models::SsModel load_ss(const std::string& path) {
  const models::AnyModel any = models::load_model(path);
  if (const auto* ss = std::get_if<models::SsModel>(&any.model)) {
    models::SsModel m = *ss;
    if (m.state_prior) {
      std::fprintf(stderr, "identify average: %s: its fitted initial state is not used; the average starts from the "
                   "encoders (convert it after: identify ss --start-from AVERAGE --epochs 0 --initial-state fit)\n", path.c_str());
      m.state_prior.reset();
    }
    return m;
  }
  throw std::invalid_argument("--models " + path + ": a " + any.kind() + " model; identify average takes ss models (identify ss)");
}

void run_identify_average(const IdentifyAverageOptions& o) {
  std::vector<models::SsModel> candidates;
  for (const std::string& path : o.models) candidates.push_back(load_ss(path));
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    // each beside the first before any free run, the refusal naming the files
    if (const auto why = models::ss_average_mismatch(candidates[0], candidates[i])) {
      throw std::invalid_argument("--models " + o.models[i] + (i > 0 ? " cannot be averaged with " + o.models[0] : "") +
                                  ": it " + *why);
    }
  }
  std::vector<int> chosen(candidates.size());
  for (std::size_t i = 0; i < chosen.size(); ++i) chosen[i] = static_cast<int>(i);
  nlohmann::json selection = nullptr;
  double j_val = NAN;
  if (!o.val.empty()) {
    const dsp::Record val = o.columns.read_at_model_rate(o.val, candidates[0].fs);
    if (o.init >= val.columns[1].size()) {
      throw std::invalid_argument("--init " + std::to_string(o.init) + " leaves nothing of --val " + o.val + " to judge");
    }
    std::vector<Eigen::VectorXd> runs;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      std::fprintf(stderr, "identify average: free run of %s on %s\n", o.models[i].c_str(), o.val.c_str());
      runs.push_back(candidates[i].simulate(val.columns[0], val.columns[1], o.init));
      if (!runs.back().allFinite()) throw std::invalid_argument("--models " + o.models[i] + ": its free run on " + o.val + " is not finite");
    }
    const models::AverageSelection s = models::select_average(runs, val.columns[1], o.init);
    chosen = s.chosen;
    j_val = s.j_percent[s.chosen.size() - 1];
    selection = nlohmann::json::array();
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      selection.push_back({{"model", o.models[i]}, {"J_val_pct", s.candidate_j_percent[i]}, {"member", false}});
    }
    for (std::size_t step = 0; step < s.order.size(); ++step) {
      nlohmann::json& c = selection[static_cast<std::size_t>(s.order[step])];
      c["added_at_step"] = step + 1;
      c["J_val_of_average_pct"] = s.j_percent[step];
      c["member"] = step < s.chosen.size();
    }
  }
  std::vector<models::SsModel> members;
  std::vector<std::string> member_files;
  for (const int i : chosen) {
    members.push_back(candidates[static_cast<std::size_t>(i)]);
    member_files.push_back(o.models[static_cast<std::size_t>(i)]);
  }
  models::SsModel average = models::ss_average(members);
  average.meta["member_files"] = member_files;
  average.meta["val"] = o.val;
  average.meta["init"] = o.init;
  average.meta["J_val_pct"] = models::number_or_null(j_val);
  models::save_ss_model(o.out, average);
  print_result({{"members", member_files},
                {"J_val_pct", models::number_or_null(j_val)},
                {"candidates", selection},
                {"states", average.structure.states},
                {"params", average.theta.size()},
                {"out", o.out}});
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
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write (an ss model: the members' states side by side)")->required();
  cmd->footer(
      "Example:\n  panelbass identify average --models wh10.json wh15.json wh20.json --val val.csv --fs 51200 --out avg.json\n"
      "  panelbass validate --model avg.json --data test.csv --fs 51200 --init 50");
  cmd->callback([o] { run_identify_average(*o); });
}

}  // namespace panelbass::cli
