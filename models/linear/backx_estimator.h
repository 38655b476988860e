#pragma once
// The FIR → Hankel-SVD → output-error method (thesis fig. 4.1, Backx), with decimation for long impulse
// responses (dsp::decimate) and conversion back to the original rate by pole mapping (rate_conversion.h).

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

}  // namespace panelbass::models
