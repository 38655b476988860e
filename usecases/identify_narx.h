#pragma once
// `identify narx` / the identify-narx job: a neural NARX model (thesis ch. 5–6) trained on its simulation error —
// from one seed's initial weights or several (usecases/narx_restarts.h, the lowest validation J kept), a hidden layer
// grown by the dX/N rule, friction-seeded nodes, a model trained on from where it is — optionally pruned by Optimal
// Brain Surgeon, judged by free-run J ([2A]) beside a linear model of the same order.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/narx/narx_model.h"
#include "models/narx/narx_multiple_shooting.h"
#include "models/narx/narx_training.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `identify narx` is asked. The structure and training defaults are the documented recipe
/// (docs/identification.md: 8/8 lags, 17 hidden nodes, pem then oem-d by Levenberg–Marquardt, 100 iterations, the
/// weight decay re-estimated by the evidence from 0.01).
struct IdentifyNarxRequest {
  Eigen::VectorXd u_est, y_est;  ///< estimation record, raw
  Eigen::VectorXd u_val, y_val;  ///< validation record (empty: none; early stopping, restarts and prune need it)
  Eigen::VectorXd w_est, w_val;  ///< per-sample weights of the loss on each part (empty: none)
  double fs = 0.0;               ///< Hz
  std::string data_name, val_name;  ///< where the records came from, kept in the model's meta
  std::optional<models::NarxModel> start_from;  ///< a model trained on from where it is (its structure and scaling)
  std::string start_from_name;                  ///< where it came from
  int na = 8;                    ///< past outputs y(k−1)…y(k−na), 0..500
  int nb = 8;                    ///< past inputs u(k−nk)…u(k−nk−nb), 0..500
  /// Input delay, −1..100000 (−1: estimated from the data, as identify linear). 0 by default: the nb + 1 past inputs
  /// from u(k) on cover a short delay, and estimating it dropped u(k) on Silverbox (J_val 0.00315 % against 0.00145 %).
  int nk = 0;
  std::vector<int> hidden{17};   ///< hidden layer widths, 1..8 layers of 1..10000 nodes
  std::vector<std::string> modes{"pem", "oem-d"};  ///< training modes in order: pem, oem-s, oem-d, oem-n, oem-ms
  std::string optimizer = "lm";  ///< lm, sd or linesearch
  int max_iterations = 100;      ///< per mode, 0..1000000
  int pem_max_iterations = models::TrainingOptions{}.pem_max_iterations;  ///< the pem mode's own limit (−1: max_iterations)
  double pem_min_progress = models::kDefaultPemMinProgress;  ///< pem stops below this progress over its last 10, [0, 0.999]
  double step = 0.1;             ///< steepest-descent step α, > 0
  long batch = 0;                ///< steepest-descent batch L (0: all samples), 0..100000000
  long skip = -1;                ///< transient skip [5M] (−1: 2(na + nb)), −1..100000000
  int patience = 20;             ///< iterations without validation improvement before a mode stops, 1..1000000
  /// Weight decay D ≥ 0 (NNSYSID's); none: models::kDefaultLmWeightDecay, 0 with the sd optimizer (which has none).
  std::optional<double> weight_decay;
  /// MacKay's evidence re-estimates the decay after each LM iteration from its Gauss–Newton matrix (weight_decay then
  /// only starts it): in "all" modes, in the output-error modes alone ("oem"; pem keeps weight_decay), or "off".
  /// none: "all" with the lm optimizer (the best recipe measured, docs/identification.md), "off" with sd or linesearch.
  std::optional<std::string> evidence_decay;
  long init = 50;                ///< measured outputs that set the state before J (at most a tenth of the shorter part)
  std::uint64_t seed = 1;        ///< the initial weights ([5F]); restart r starts from seed + r
  int restarts = 1;              ///< trainings from seeds seed … seed + restarts − 1, the lowest validation J kept
  int grow = 0;                  ///< grow the hidden layer from 1 node up to this by the dX/N rule (0: no), 0..1000
  bool prune = false;            ///< Optimal Brain Surgeon with retraining while validation J stays within 5 %
  std::vector<double> friction_units;  ///< gains g of first-layer nodes seeded as tanh(g·v), each (0, 1000], ≤ 16
  int friction_lags = 1;               ///< the velocities v(k)…v(k−L+1) seeded too, 1..100
  models::MultipleShootingOptions multiple_shooting;  ///< the oem-ms mode's windows and continuity penalty
};

/// What `identify narx` made.
struct IdentifyNarxReport {
  models::NarxModel model;  ///< its meta filled in (the history in meta.history)
  /// {"J_est_pct","J_val_pct","na","nb","nk","nk_source","hidden","modes","optimizer","evidence_decay","params","iterations","seconds",
  /// "weighted","linear_reference_J_pct","structure":{"restarts"|"growth"|"pruning"|"friction_units"}}
  nlohmann::json summary;
  std::vector<models::TrainingRecord> history;  ///< J per iteration of the kept training
  std::vector<std::string> warnings;  ///< a fit no better than an output of zero or a linear model, with what to try
};

/// Throws RequestError naming the field for a request out of range or inconsistent; the records' checks (lengths,
/// restarts and prune without validation data, start_from's rate) only once there are records (u_est not empty).
void check(const IdentifyNarxRequest& request);

/// The request's fields (the records and model by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifyNarxRequest& request);

/// The evidence rule the request asks for: its evidence_decay, or the default ("all" with lm, else "off").
std::string evidence_decay_of(const IdentifyNarxRequest& request);

/// Trains the model; std::runtime_error when the trained network's free run diverges (no model to write).
IdentifyNarxReport identify_narx(const IdentifyNarxRequest& request, Progress& progress);

/// The static, dynamic and finite-difference gradients of the loss in parameter `parameter` (thesis fig. 5.16), at
/// a short PEM fit of the request's start: {"parameter","static","dynamic","finite_difference"}.
nlohmann::json narx_gradient_check(const IdentifyNarxRequest& request, long parameter);

}  // namespace panelbass::usecases
