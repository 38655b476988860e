#pragma once
// The FIR → Hankel-SVD → output-error method (thesis fig. 4.1, Backx), with decimation for long impulse
// responses and conversion between sample rates by pole mapping (thesis appendix 2).

#include <Eigen/Core>

#include "models/linear/arx_estimator.h"
#include "models/linear/oe_estimator.h"
#include "models/linear/state_space.h"

namespace panelbass::models {

/// How the Backx method runs.
struct BackxOptions {
  Eigen::Index fir_taps = 0;  ///< Markov parameters estimated; 0 = from the impulse-length estimate
  int decimation = 1;         ///< integer decimation factor before the FIR step (1 = none)
  OeOptions oe;
};

/// What the Backx method produced.
struct BackxResult {
  TransferFunction tf;                     ///< final model at the original rate
  TransferFunction reduced;                ///< Hankel-reduced model (before OE), at the original rate
  Eigen::VectorXd hankel_singular_values;  ///< of the FIR's Hankel matrix, descending
  Eigen::VectorXd fir;                     ///< the Markov parameters (at the decimated rate)
  OeResult oe;
};

/// Fits an FIR by least squares (at fs/decimation, behind a Butterworth anti-alias filter, when
/// decimation > 1), reduces it to `orders.na` states by SVD of its Hankel matrix (Kung's realisation),
/// maps the model back to fs, and refines it by output error on the original data.
BackxResult estimate_backx(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders,
                           double fs, const BackxOptions& options = {});

/// Kung's realisation: a state-space model of `order` states whose Markov parameters approximate
/// `impulse` (impulse[0] = D, impulse[k] = C·A^(k−1)·B), from the SVD of their Hankel matrix.
/// `singular_values` (optional) receives the Hankel singular values.
StateSpace hankel_reduction(const Eigen::VectorXd& impulse, int order, Eigen::VectorXd* singular_values = nullptr);

/// The same dynamics at another sample rate (thesis appendix 2): each mode of the partial-fraction
/// expansion keeps its continuous-time decay and frequency (λ → λ^(fs_from/fs_to)), its residue scaled
/// by fs_from/fs_to (impulse invariance), the direct term kept. Throws std::invalid_argument for a pole
/// on the negative real axis (no continuous-time equivalent) or repeated poles.
TransferFunction convert_rate(const TransferFunction& tf, double fs_from, double fs_to);

/// `x` low-pass filtered (Butterworth, order 8, forward and backward so no phase is added, cutoff
/// 0.8·fs/(2·factor)) and kept every `factor`-th sample.
Eigen::VectorXd decimate(const Eigen::VectorXd& x, int factor);

}  // namespace panelbass::models
