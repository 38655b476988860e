#include "usecases/identify_average.h"

#include <cmath>

#include "models/io/json_fields.h"
#include "models/state_space_nn/ss_average.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

using nlohmann::json;

void check(const IdentifyAverageRequest& q) {
  if (q.models.empty()) throw RequestError("models", "needs at least one ss model");
  if (q.model_names.size() != q.models.size()) throw RequestError("models", "each model needs its name");
  for (std::size_t i = 0; i < q.models.size(); ++i) {
    // each beside the first before any free run, the refusal naming both
    if (const auto why = models::ss_average_mismatch(q.models[0], q.models[i])) {
      throw RequestError("models", q.model_names[i] + (i > 0 ? " cannot be averaged with " + q.model_names[0] : "") +
                                       ": it " + *why);
    }
  }
  if (q.init < 0) throw RequestError("init", "must be ≥ 0, got " + std::to_string(q.init));
  if (q.u_val.size() != q.y_val.size()) throw RequestError("record", "the drive and response differ in length");
  if (q.u_val.size() > 0 && q.init >= q.y_val.size()) {
    throw RequestError("init", std::to_string(q.init) + " leaves nothing of the validation record (" +
                                   std::to_string(q.y_val.size()) + " samples) to judge");
  }
}

json to_json(const IdentifyAverageRequest& q) {
  return {{"models", q.model_names}, {"record", q.val_name}, {"init", q.init}};
}

IdentifyAverageReport identify_average(const IdentifyAverageRequest& q, Progress& progress) {
  check(q);
  IdentifyAverageReport report;
  std::vector<models::SsModel> candidates = q.models;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    // Started by its encoder, as the written average will be: the members' priors do not combine.
    if (candidates[i].state_prior) {
      report.warnings.push_back(q.model_names[i] + ": its fitted initial state is not used; the average starts from "
                                "the encoders (convert it after: identify ss --start-from AVERAGE --epochs 0 "
                                "--initial-state fit)");
      candidates[i].state_prior.reset();
    }
  }
  std::vector<int> chosen(candidates.size());
  for (std::size_t i = 0; i < chosen.size(); ++i) chosen[i] = static_cast<int>(i);
  json selection = nullptr;
  double j_val = NAN;
  if (q.u_val.size() > 0) {
    std::vector<Eigen::VectorXd> runs;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      progress.report(static_cast<double>(i) / static_cast<double>(candidates.size()),
                      "free run of " + q.model_names[i] + " on " + q.val_name);
      runs.push_back(candidates[i].simulate(q.u_val, q.y_val, q.init));
      if (!runs.back().allFinite()) {
        throw RequestError("models", q.model_names[i] + ": its free run on " + q.val_name + " is not finite");
      }
    }
    const models::AverageSelection s = models::select_average(runs, q.y_val, q.init);
    chosen = s.chosen;
    j_val = s.j_percent[s.chosen.size() - 1];
    selection = json::array();
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      selection.push_back({{"model", q.model_names[i]}, {"J_val_pct", s.candidate_j_percent[i]}, {"member", false}});
    }
    for (std::size_t step = 0; step < s.order.size(); ++step) {
      json& c = selection[static_cast<std::size_t>(s.order[step])];
      c["added_at_step"] = step + 1;
      c["J_val_of_average_pct"] = s.j_percent[step];
      c["member"] = step < s.chosen.size();
    }
  }
  std::vector<models::SsModel> members;
  std::vector<std::string> member_names;
  for (const int i : chosen) {
    members.push_back(candidates[static_cast<std::size_t>(i)]);
    member_names.push_back(q.model_names[static_cast<std::size_t>(i)]);
  }
  report.model = models::ss_average(members);
  report.model.meta["member_files"] = member_names;
  report.model.meta["val"] = q.val_name;
  report.model.meta["init"] = q.init;
  report.model.meta["J_val_pct"] = models::number_or_null(j_val);
  report.summary = {{"members", member_names},
                    {"J_val_pct", models::number_or_null(j_val)},
                    {"candidates", selection},
                    {"states", report.model.structure.states},
                    {"params", report.model.theta.size()}};
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases
