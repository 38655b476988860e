#pragma once
// `identify narx --restarts` / the identify-narx job's `restarts`: the same NARX training from several seeds'
// initial weights ([5F]), the model of the lowest validation J ([2A], the first `options.init` measured outputs
// setting its state, as training judges it) kept.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>

#include "models/narx/narx_model.h"
#include "models/narx/narx_training.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// Most trainings one request may ask for.
inline constexpr int kMaxNarxRestarts = 1000;

/// What a NARX training from one or more seeds is asked.
struct NarxRestartsRequest {
  models::NarxModel start;          ///< the first training's start: its structure and scaling, its weights drawn from `seed`
  bool fresh_start = true;          ///< false when `start` is a model trained on or has seeded units (then one training)
  Eigen::VectorXd u_est, y_est;     ///< estimation record, raw
  Eigen::VectorXd u_val, y_val;     ///< validation record, raw (empty: none; more than one training needs it)
  models::TrainingOptions options;  ///< each training's (its progress callback is the use case's)
  std::uint64_t seed = 1;           ///< the first training's seed; training r starts from the weights of seed + r
  int restarts = 1;                 ///< trainings, 1..kMaxNarxRestarts
};

/// What the trainings made.
struct NarxRestartsReport {
  models::TrainingResult result;  ///< the kept training; its iterations and seconds the totals of all
  std::uint64_t chosen_seed = 1;  ///< the seed of the kept training
  /// {"tried":[{"seed","J_val_pct"}…],"chosen_seed"} with more than one training; null with one.
  nlohmann::json restarts;
};

/// Throws RequestError naming "restarts" for a count out of range, or more than one training without validation
/// data (`validated` false) or from a start that is not a seed's draw (`fresh_start` false).
void check_restarts(int restarts, bool fresh_start, bool validated);

/// check_restarts() of the request, and RequestError "record" for parts whose drive and response differ in length.
void check(const NarxRestartsRequest& request);

/// Trains `request.start` and, for r = 1 … restarts − 1, the same structure from the weights of seed + r; keeps the
/// model of the lowest validation J.
NarxRestartsReport train_narx_restarts(const NarxRestartsRequest& request, Progress& progress);

}  // namespace panelbass::usecases
