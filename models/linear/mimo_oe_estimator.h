#pragma once
// Output-error refinement of a multi-input multi-output state space on periodic steady-state data: the
// last step of the FIR → Hankel → OE route (thesis fig. 4.1) made MIMO. For a periodic input in steady
// state the simulated output's DFT is G(z_k)·U(k) exactly, so the simulation error over one period equals
// (Parseval) the sum over the DFT lines of |Y(k) − G(z_k)·U(k)|²: the cost and its exact Jacobian are
// evaluated line by line, with no transient and no N×P sensitivity recursion.

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "models/linear/mimo_state_space.h"

namespace panelbass::models {

/// One steady-state period per realisation, as DFT lines 0..N/2 (what the simulation error is taken over).
struct PeriodicSpectra {
  Eigen::Index period = 0;            ///< N
  Eigen::VectorXd weight;             ///< Parseval weight of line k: (1 at k = 0 and N/2, else 2)/N
  std::vector<Eigen::MatrixXcd> U;    ///< U[r]: (N/2+1)×m input lines of realisation r
  std::vector<Eigen::MatrixXcd> Y;    ///< Y[r]: (N/2+1)×p output lines
  double output_energy = 0.0;         ///< Σ_r Σ_t |y_r(t)|², the J's denominator
};

/// The spectra of realisations u[r] (N×m) and y[r] (N×p), one steady-state period each.
/// Throws std::invalid_argument for mismatched shapes or N < 2.
PeriodicSpectra periodic_spectra(const std::vector<Eigen::MatrixXd>& u, const std::vector<Eigen::MatrixXd>& y);

/// Σ_r Σ_t |y_r(t) − ŷ_r(t)|² over one period with ŷ the steady-state periodic response of `ss`
/// (computed from the spectra; equal to the time-domain sum by Parseval).
double steady_state_error(const MimoStateSpace& ss, const PeriodicSpectra& data);

/// A state space in real modal form: A block-diagonal with 2×2 blocks [[σ, ω], [−ω, σ]] (the pole pair
/// σ ± jω) first, then 1×1 blocks (real poles); B, C, D full. The parameters of the refinement.
struct ModalStateSpace {
  Eigen::VectorXd sigma, omega;  ///< one entry per complex pole pair
  Eigen::VectorXd real_poles;    ///< one entry per real pole
  Eigen::MatrixXd B, C, D;

  /// The state space (A assembled from the blocks).
  MimoStateSpace state_space() const;
  /// θ = [σ₁, ω₁, …, real poles, vec B, vec C, vec D] (column-major vecs).
  Eigen::VectorXd theta() const;
  /// Sets the parameters from θ (same layout and sizes).
  void set_theta(const Eigen::VectorXd& theta);
  /// The largest pole magnitude.
  double spectral_radius() const;
};

/// `ss` in real modal form by a similarity transform (the eigenvectors' real and imaginary parts). Poles on
/// or outside the unit circle are reflected inside (z → z/|z|², the same frequency), so the start is stable.
/// Throws std::invalid_argument when A's eigenvectors are too ill conditioned for the transform (a defective A).
ModalStateSpace modal_form(const MimoStateSpace& ss);

/// The weighted residuals √w_k·(Y_r(k) − G(z_k)·U_r(k)) as real rows ([Re; Im] per output, lines then
/// realisations), whose squared norm is steady_state_error.
Eigen::VectorXd modal_residuals(const ModalStateSpace& model, const PeriodicSpectra& data);

/// The exact Jacobian d(modal_residuals)/dθ (rows as modal_residuals, columns as ModalStateSpace::theta).
Eigen::MatrixXd modal_jacobian(const ModalStateSpace& model, const PeriodicSpectra& data);

/// One iteration of the refinement, as reported to the progress callback.
struct MimoRefinementRecord {
  int iteration = 0;        ///< 0 = the start
  double j_est_pct = 0.0;   ///< steady-state J on the estimation data, %
  double j_val_pct = 0.0;   ///< steady-state J on the validation data (the estimation J without any), %
  double lambda = 0.0;      ///< the LM damping after the step
};

/// How the refinement runs.
struct MimoRefinementOptions {
  int max_iterations = 100;   ///< Levenberg–Marquardt steps at most
  /// Called after every iteration; returning false stops the refinement (the best iterate is kept).
  std::function<bool(const MimoRefinementRecord&)> progress;
};

/// The refined model, the one of lowest validation J over all iterates (the start included).
struct MimoRefinement {
  MimoStateSpace model;
  int iterations = 0;                          ///< steps taken
  int best_iteration = 0;                      ///< the iterate returned
  double j_est_pct = 0.0, j_val_pct = 0.0;     ///< of the returned model
  std::vector<MimoRefinementRecord> history;   ///< every iterate, the start first
};

/// Levenberg–Marquardt on the steady-state simulation error of `estimation` from `start` in modal form,
/// with the exact Jacobian, rejecting unstable candidates; keeps the iterate with the lowest J on
/// `validation` (on `estimation` when `validation` has no realisations). Stops after max_iterations, when
/// no damped step lowers the loss, or when the progress callback says so.
MimoRefinement refine_mimo(const MimoStateSpace& start, const PeriodicSpectra& estimation,
                           const PeriodicSpectra& validation, const MimoRefinementOptions& options = {});

}  // namespace panelbass::models
