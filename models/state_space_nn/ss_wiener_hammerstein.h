#pragma once
// A Wiener–Hammerstein start for the neural state-space model: the best linear approximation's poles and
// zeros split between a front and a back filter, a static nonlinearity between them (tanh nodes, a linear
// term and a constant, fitted by least squares), the split of the lowest selection J kept — then written
// exactly as an SsModel (the front filter's states first), so that the state-space trainer refines every
// parameter jointly on the simulation error.

#include <Eigen/Core>
#include <cstdint>

#include "models/linear/linear_model.h"
#include "models/linear/transfer_function.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// A Wiener–Hammerstein block model (in the model's scaled units): y = G2·g(G1·u) from rest, with
/// g(v) = p₀ + p₁·v + Σᵢ p₁₊ᵢ·tanh(wᵢ·(v − cᵢ)).
struct WhBlocks {
  TransferFunction front;        ///< G1, with the input delay
  TransferFunction back;         ///< G2
  Eigen::VectorXd coefficients;  ///< p₀, p₁, p₂ … (nodes + 2)
  Eigen::VectorXd centres;       ///< cᵢ
  Eigen::VectorXd slopes;        ///< wᵢ
  /// θ = [front a, front b, back a, back b, p, c, w].
  Eigen::VectorXd pack() const;
  /// These blocks with θ (laid out as pack()'s) for their parameters; throws std::invalid_argument on a wrong size.
  WhBlocks unpack(const Eigen::VectorXd& theta) const;
};

/// The block model's output to `u` from rest.
Eigen::VectorXd wh_block_output(const WhBlocks& blocks, const Eigen::VectorXd& u);

/// ∂ŷ/∂θ of wh_block_output (N×P, θ as WhBlocks::pack lays it out), exact.
Eigen::MatrixXd wh_block_jacobian(const WhBlocks& blocks, const Eigen::VectorXd& u);

/// The Wiener–Hammerstein start and how it was chosen.
struct SsWienerHammerstein {
  SsModel model;            ///< the block model written as a state-space model (front states first)
  int front_poles = 0;      ///< poles of the best linear approximation given to the front filter
  int front_zeros = 0;      ///< zeros given to the front filter (the input delay always goes there)
  int front_states = 0;     ///< states of the front filter's realisation
  int splits = 0;           ///< splits tried
  double search_j_pct = 0.0;  ///< the kept split's J on (the first 20000 samples of) the selection data, from rest
  double j_pct = 0.0;       ///< its J on the selection data from rest after the joint refinement
  int iterations = 0;       ///< Levenberg–Marquardt steps taken (it stops early when the loss stalls)
  double linear_j_pct = 0.0;  ///< the best linear approximation's J there, from rest
  int candidates = 1;       ///< splits of the search refined before one was kept
};

/// Splits `bla`'s poles and zeros (real ones and complex-conjugate pairs whole) every way between a front
/// filter G1 (with the input delay) and a back filter G2; for each, the front filter's output v is scaled
/// to unit RMS along the raw estimation data u, y, and y ≈ G2·g(v) with
/// g(v) = p₀ + p₁·v + Σᵢ p₁₊ᵢ·tanh(w·(v − cᵢ)), structure.hidden nodes spaced evenly over v's range, is fitted
/// by (ridge) least squares; the split of the lowest J on u_val, y_val (the estimation data when empty) is
/// written as an SsModel: A = [A1 0; p₁B2C1 A2], W1's rows w·[C1 0 D1], W2's columns p₁₊ᵢ·[0; B2; D2], and the
/// encoder's affine part the least-squares map to its states along the estimation data. At most 20000
/// estimation samples take part in the search. Before it is written, the kept split's every parameter (both
/// filters' coefficients, g's coefficients, centres and slopes) is refined jointly by Levenberg–Marquardt on
/// the simulation error over the whole estimation data, exact Jacobian, at most `iterations` steps, the
/// iterate of the lowest selection J kept (0: no refinement). With `candidates` > 1 the search's best
/// `candidates` splits are each refined for min(iterations, 20) steps first, and the one of the lowest
/// selection J after them is the one refined on. Only splits and iterates whose model (encoder aside) has a
/// bounded free run (ss_free_run_runaway) are kept while any is; the caller's trainer tests the start again. Throws std::invalid_argument when structure.hidden is 0,
/// `bla` has no pole, or the data are too short for the encoder's lags.
SsWienerHammerstein ss_wiener_hammerstein_start(const LinearModel& bla, SsStructure structure, const Eigen::VectorXd& u,
                                                const Eigen::VectorXd& y, const Eigen::VectorXd& u_val,
                                                const Eigen::VectorXd& y_val, int iterations, std::uint64_t seed,
                                                int candidates = 1);

}  // namespace panelbass::models
