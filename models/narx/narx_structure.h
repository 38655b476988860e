#pragma once
// Choosing the NARX network's structure (thesis ch. 6 "Suggestion to choose structure", and the
// conclusion's first recommendation: remove the redundant parameters). Two tools:
// - pruning by Optimal Brain Surgeon (Hassibi & Stork) with the Gauss–Newton Hessian of the simulation
//   loss: weights are removed one by one, the others corrected, and the net retrained briefly, while the
//   validation J stays within a tolerance;
// - growing the hidden layer one node at a time while the relative improvement of the estimation J
//   exceeds dX/N (dX = parameters one node adds, N = estimation samples in the loss).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "models/narx/narx_model.h"
#include "models/narx/narx_training.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {

// ----- Optimal Brain Surgeon ----------------------------------------------------------------------

/// One OBS candidate: removing weight `index` (θ_q → 0) raises the quadratic loss by `saliency` at best,
/// reached by adding `delta` to θ.
struct ObsRemoval {
  Eigen::Index index = -1;
  double saliency = 0.0;   ///< L_q = θ_q² / (2 [H⁻¹]_qq), in the loss's units
  Eigen::VectorXd delta;   ///< δθ = −θ_q / [H⁻¹]_qq · H⁻¹ e_q (δθ_q = −θ_q)
};

/// The OBS saliency and step for weight q, given H⁻¹ of the loss's Hessian (over the free weights; rows
/// and columns of pruned weights zero). Throws std::invalid_argument for mismatched sizes, q out of range
/// or [H⁻¹]_qq ≤ 0.
ObsRemoval obs_removal(const Eigen::MatrixXd& H_inv, const Eigen::VectorXd& theta, Eigen::Index q);

/// The free weight (mask 1; empty mask = all free) of smallest saliency. Throws std::invalid_argument
/// when no weight is free or sizes do not match.
ObsRemoval obs_best_removal(const Eigen::MatrixXd& H_inv, const Eigen::VectorXd& theta, const Eigen::VectorXd& mask);

/// After removing weight q: H⁻¹ of the remaining free weights by the rank-one (Schur complement) update
/// H⁻¹ ← H⁻¹ − H⁻¹e_q e_qᵀH⁻¹ / [H⁻¹]_qq; row and column q become exactly 0.
void obs_downdate_inverse(Eigen::MatrixXd& H_inv, Eigen::Index q);

/// How pruning runs.
struct PruningOptions {
  double relative_tolerance = 0.05;   ///< accept while J_val ≤ J_val,before·(1 + this) + absolute_tolerance_pct
  double absolute_tolerance_pct = 0.0;  ///< in percentage points of J (for an almost perfect unpruned model)
  int batch = 2;                      ///< weights removed (rank-one updates of H⁻¹) per round before retraining
  int retrain_iterations = 5;         ///< LM iterations of `mode` after each round (0 = OBS correction only)
  int max_removed = -1;               ///< at most this many weights removed; −1 = no limit
  int min_free = 1;                   ///< never fewer free weights than this
  double hessian_damping = 1e-6;      ///< H + δ·mean(diag H)·I before inversion (H is singular for redundant nets)
  TrainingMode mode = TrainingMode::oem_d;  ///< sensitivities of the Hessian and the retraining (simulation loss)
  Eigen::Index transient_skip = -1;   ///< samples left out of the loss and J; −1 = 2·(na + nb)
  Eigen::Index init = 0;              ///< measured outputs setting the state, as TrainingOptions::init
  Eigen::VectorXd weights;            ///< per-sample weights of the estimation loss (TrainingOptions::weights)
                                      ///< for the saliencies and the retraining; empty = 1. J stays unweighted
};

/// One round of pruning: the weights removed, and the figures after retraining.
struct PruningStep {
  std::vector<Eigen::Index> removed;  ///< θ indices, in the order removed
  std::vector<double> saliency;       ///< L_q of each when it was removed (loss units, V = ½·mean e²)
  Eigen::Index free = 0;              ///< free weights after the round
  double j_est_pct = 0.0;             ///< simulation J on the estimation data after retraining
  double j_val_pct = 0.0;             ///< simulation J on the validation data after retraining
  bool accepted = false;              ///< J_val within the tolerance; a rejected round is undone
};

/// What pruning produced.
struct PruningResult {
  NarxModel model;                 ///< the pruned, retrained model (pruned weights exactly 0)
  Eigen::VectorXd mask;            ///< 1 = kept, 0 = pruned (the last acceptable mask)
  int removed = 0;                 ///< weights pruned
  double j_est_before_pct = 0.0, j_est_after_pct = 0.0;
  double j_val_before_pct = 0.0, j_val_after_pct = 0.0;
  double j_val_limit_pct = 0.0;    ///< the largest acceptable validation J
  std::vector<PruningStep> steps;  ///< every round, rejected ones included
  std::string stop_reason;         ///< why pruning stopped, in words
};

/// Prunes `trained` by Optimal Brain Surgeon on scaled data (as train_narx): H is the Gauss–Newton
/// Hessian of the simulation loss at θ; the weight of least saliency goes, the others move by δθ, H⁻¹ is
/// downdated; after `batch` removals the net is retrained (LM, the mask holding pruned weights at 0) and
/// the round is kept if the validation J stays within the tolerance. A rejected round is undone and
/// retried with half the batch; a rejected single removal ends the search. Throws std::invalid_argument
/// for bad options or data.
PruningResult prune_obs(const NarxModel& trained, const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                        const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const PruningOptions& options);

// ----- growing the hidden layer ----------------------------------------------------------------------

/// One network size tried.
struct GrowthStep {
  int hidden = 0;                  ///< nodes in the (single) hidden layer
  double j_est_pct = 0.0;          ///< simulation J on the estimation data
  double j_val_pct = 0.0;          ///< simulation J on the validation data (NaN without)
  Eigen::Index params = 0;         ///< P
  double improvement = 0.0;        ///< (J_est(h−1) − J_est(h)) / J_est(h−1); 0 for the first size
  double threshold = 0.0;          ///< dX/N for this step; 0 for the first size
};

/// How growing decides, beyond the training options.
struct GrowthOptions {
  /// The threshold is factor·dX/N; 1 is the thesis's rule. The rule assumes every parameter fits one
  /// noise sample's worth of loss; a tanh node whose input weights are free fits noise by more than its dX
  /// (its effective degrees of freedom exceed its parameter count), so at the noise floor the thesis's
  /// rule tends to keep adding nodes; a factor > 1 is the stricter rule.
  double threshold_factor = 1.0;
  /// Fresh [5F] random starts per size besides the warm start from the smaller net; the net with the
  /// least estimation J is kept (ch. 6: "you never know if the global minimum is found").
  int restarts = 0;
};

/// What growing produced.
struct GrowthResult {
  NarxModel model;                 ///< the trained network of the chosen size
  std::vector<GrowthStep> steps;   ///< every size trained, in order
  int chosen_hidden = 0;
  std::string rule;                ///< the decision in words, with the numbers
};

/// The thesis's rule (ch. 6): train a net with one hidden node (one hidden layer; base.hidden is ignored),
/// then add a node at a time, starting each larger net from the trained smaller one plus a new node whose
/// output weight is 0 (so it starts at the smaller net's J), and from `growth.restarts` fresh random
/// starts; keep the larger net while the relative improvement of the estimation J exceeds dX/N (times
/// growth.threshold_factor), dX = na + nb + 3 (the new node's input weights, bias and output weight), N =
/// estimation samples in the loss. Scaled data; `options` trains each candidate. Throws
/// std::invalid_argument for max_hidden < 1, bad growth options and whatever train_narx rejects.
GrowthResult grow_hidden_nodes(const NarxStructure& base, const Scaling& scaling, double fs, const Eigen::VectorXd& u_est,
                               const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val,
                               const TrainingOptions& options, int max_hidden, std::uint64_t seed,
                               const GrowthOptions& growth = {});

}  // namespace panelbass::models
