#include "usecases/narx_restarts.h"

#include <algorithm>
#include <string>
#include <utility>

#include "models/io/json_fields.h"
#include "models/validation/performance.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

void check_restarts(int restarts, bool fresh_start, bool validated) {
  if (restarts < 1 || restarts > kMaxNarxRestarts) {
    throw RequestError("restarts", "must be within 1.." + std::to_string(kMaxNarxRestarts) + ", got " + std::to_string(restarts));
  }
  if (restarts == 1) return;
  if (!validated) {
    throw RequestError("restarts", std::to_string(restarts) +
                                       " trainings need validation data: the one of the lowest validation J is kept");
  }
  if (!fresh_start) {
    throw RequestError("restarts", std::to_string(restarts) +
                                       " trainings start from their seeds' weights: not from a model trained on, grown "
                                       "or seeded with friction units");
  }
}

void check(const NarxRestartsRequest& q) {
  if (q.u_est.size() != q.y_est.size() || q.u_val.size() != q.y_val.size()) {
    throw RequestError("record", "a part's drive and response differ in length");
  }
  check_restarts(q.restarts, q.fresh_start, q.u_val.size() > 0);
}

NarxRestartsReport train_narx_restarts(const NarxRestartsRequest& q, Progress& progress) {
  check(q);
  const models::Scaling& scaling = q.start.scaling;
  const Eigen::VectorXd us = scaling.scale_u(q.u_est), ys = scaling.scale_y(q.y_est);
  const Eigen::VectorXd uv = q.u_val.size() ? scaling.scale_u(q.u_val) : Eigen::VectorXd(),
                        yv = q.y_val.size() ? scaling.scale_y(q.y_val) : Eigen::VectorXd();
  models::TrainingOptions options = q.options;
  const int per_training = std::max(1, options.max_iterations * static_cast<int>(options.modes.size()));  // no 0/0
  int training = 0, done = 0;
  options.progress = [&](const models::TrainingRecord& r) {
    if (r.iteration > 0) done = std::min(done + 1, per_training);
    std::string message = models::to_string(r.mode) + " iteration " + std::to_string(r.iteration);
    if (q.restarts > 1) message += " (training " + std::to_string(training + 1) + " of " + std::to_string(q.restarts) + ")";
    progress.report((training + static_cast<double>(done) / per_training) / q.restarts, message);
  };
  // The J training keeps a model by, in raw units: the first `init` measured outputs set the state, then free run.
  const auto j_val_of = [&](const models::NarxModel& m) {
    return models::j_percent(m.simulate(q.u_val, q.y_val, options.init), q.y_val, options.init);
  };

  NarxRestartsReport report;
  report.result = models::train_narx(q.start, us, ys, uv, yv, options);
  report.chosen_seed = q.seed;
  if (q.restarts == 1) return report;
  double best = j_val_of(report.result.model);
  nlohmann::json tried = nlohmann::json::array({{{"seed", q.seed}, {"J_val_pct", models::number_or_null(best)}}});
  for (training = 1; training < q.restarts; ++training) {
    done = 0;
    const std::uint64_t seed = q.seed + static_cast<std::uint64_t>(training);
    models::NarxModel start = q.start;
    start.net.initialize(1.0, seed);
    models::TrainingResult other = models::train_narx(start, us, ys, uv, yv, options);
    const double j = j_val_of(other.model);
    tried.push_back({{"seed", seed}, {"J_val_pct", models::number_or_null(j)}});
    other.seconds += report.result.seconds;
    other.iterations += report.result.iterations;
    if (j < best) {
      best = j;
      report.chosen_seed = seed;
      report.result = std::move(other);
    } else {
      report.result.seconds = other.seconds;
      report.result.iterations = other.iterations;
    }
  }
  report.restarts = {{"tried", tried}, {"chosen_seed", report.chosen_seed}};
  return report;
}

}  // namespace panelbass::usecases
