#pragma once
// Multiple shooting for the NARX model's output-error training: the estimation record cut into windows, each
// window simulated from a free initial output history h_w = [ŷ(s_w−1) .. ŷ(s_w−na)], the histories tied to
// the previous window's last outputs by a continuity penalty, and θ with every h_w stepped together by
// Levenberg–Marquardt on the exact sensitivities of the stack. A long free run is a deep, badly conditioned
// composition of the network; windows restarted from (nearly) measured histories are short ones, so the
// optimiser walks a smoother landscape, and the penalty, tightened as it goes, joins the windows back into
// one simulation. The model is still judged by its free run over the whole record (narx_training).

#include <Eigen/Core>
#include <vector>

#include "models/narx/narx_model.h"

namespace panelbass::models {

/// How multiple shooting cuts the record and weighs continuity.
struct MultipleShootingOptions {
  Eigen::Index window = 250;    ///< samples per window (≥ na, ≥ 1); the last window takes the remainder
  double penalty = 1.0;         ///< ρ at the start: one continuity residual weighs as ρ sample errors
  double penalty_growth = 1.0;  ///< ρ × this after every accepted step (1 = constant, measured best: docs)
  double penalty_max = 1e4;     ///< ρ grows no further
};

/// Throws std::invalid_argument naming the option when `o` cannot run on a model with `na` past outputs.
void require_multiple_shooting_options(const MultipleShootingOptions& o, int na);

/// One multiple-shooting run over a record (scaled units): its windows, their free initial histories and the
/// penalty weight ρ, and the stacked loss, gradient and Gauss–Newton matrix over z = [θ; h_0; …; h_{W−1}].
/// V(z) = 1/(2·Σw)·(Σ_{k≥start} w(k)·e(k)² + ρ·Σ_{w≥1} ‖h_w − ŷ_{w−1}(end)‖²), e(k) = ŷ(k) − y(k) with ŷ the
/// window's simulation from h_w, ŷ_{w−1}(end) = [ŷ(s_w−1) .. ŷ(s_w−na)] simulated in window w−1.
class MultipleShooting {
 public:
  /// Windows over k ∈ [start, N) of `options.window` samples (the last one longer, up to 2·window − 1), the
  /// histories started at the measured outputs (0 before the record), ρ = options.penalty. `weights`: w(k)
  /// (empty = 1), checked by the caller. Throws std::invalid_argument for bad options or too short a record.
  MultipleShooting(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index start,
                   const MultipleShootingOptions& options, const Eigen::VectorXd& weights = Eigen::VectorXd());

  /// Number of windows W.
  Eigen::Index windows() const { return static_cast<Eigen::Index>(starts_.size()) - 1; }
  /// First sample of window w (w = W: the record's end).
  Eigen::Index window_start(Eigen::Index w) const { return starts_[static_cast<std::size_t>(w)]; }
  /// The histories, na·W entries: h_w[i] = ŷ(s_w − 1 − i) at w·na + i.
  const Eigen::VectorXd& histories() const { return histories_; }
  /// The histories, to change (the size must stay na·W).
  Eigen::VectorXd& histories() { return histories_; }
  /// The penalty weight ρ.
  double penalty() const { return penalty_; }
  /// ρ × penalty_growth, at most penalty_max (after an accepted step).
  void tighten() { penalty_ = std::min(penalty_ * options_.penalty_growth, std::max(options_.penalty_max, penalty_)); }
  /// Σ_{k≥start} w(k): the loss's normaliser.
  double weight_total() const { return weight_total_; }

  /// V at θ = model's parameters and the given histories.
  double loss(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories);
  /// V, g = dV/dz (size P + na·W) and, if H is given, the Gauss–Newton matrix 1/Σw·Σ r_z·r_zᵀ over the stack's
  /// residuals (the samples' √w·e and the continuity's √ρ·c), from the exact sensitivities of each window's
  /// simulation to θ and to its history.
  double gradient(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories, Eigen::VectorXd& g,
                  Eigen::MatrixXd* H);

 private:
  /// Simulates window w from its history into sim_ (and, with sensitivities, ψ into ring_/tail_); adds its
  /// residuals to the sums (and, with sensitivities, to the local gradient and matrix).
  double window_sweep(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories, Eigen::Index w,
                      bool sensitivities);
  double weight(Eigen::Index k) const { return weights_.size() == 0 ? 1.0 : weights_[k]; }

  MultipleShootingOptions options_;
  int na_, nb_, nk_;
  Eigen::Index P_;
  Eigen::VectorXd u_, y_, weights_;
  double weight_total_ = 0.0;
  std::vector<Eigen::Index> starts_;
  Eigen::VectorXd histories_;
  double penalty_;
  // scratch, sized once
  Mlp::Workspace ws_;
  Eigen::VectorXd x_, dtheta_, dx_, sim_;   ///< sim_: na history entries then the window's outputs
  Eigen::MatrixXd ring_;                    ///< (P+na)×na: ψ = d[ŷ]/d[θ; h_w] of the last na outputs
  Eigen::MatrixXd tail_;                    ///< (P+na)×na: ψ of the previous window's last na outputs, newest first
  Eigen::VectorXd tail_y_;                  ///< their values
  Eigen::MatrixXd block_;                   ///< (P+2na)×B residual gradients over [θ; h_{w−1}; h_w], for H += B·Bᵀ
  Eigen::Index in_block_ = 0;
  Eigen::MatrixXd local_h_;                 ///< (P+2na)² Gauss–Newton matrix of one window
  Eigen::VectorXd local_g_, row_;           ///< (P+2na): gradient of one window, one residual's gradient
};

}  // namespace panelbass::models
