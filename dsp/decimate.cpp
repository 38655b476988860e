#include "dsp/decimate.h"

#include <stdexcept>
#include <string>

#include "dsp/biquad.h"
#include "dsp/butterworth.h"

namespace panelbass::dsp {

Eigen::VectorXd decimate(const Eigen::VectorXd& x, int factor) {
  if (factor < 1) throw std::invalid_argument("decimate: factor must be >= 1, got " + std::to_string(factor));
  if (factor == 1) return x;
  // Cutoff 0.8 of the new Nyquist frequency: 0.8·fs/(2·factor) = 0.4·fs/factor, with fs = 1.
  dsp::SosFilter filter(dsp::butterworth_lowpass(8, 0.4 / factor, 1.0));
  // Forward, then backward over the reversed signal: |H|² and no phase. Both passes start at rest, so
  // the first and last few filter lengths carry its transients.
  Eigen::VectorXd forward = filter.process(x);
  filter.reset();
  const Eigen::VectorXd reversed = forward.reverse();
  const Eigen::VectorXd both = filter.process(reversed).reverse();
  const Eigen::Index n = (x.size() + factor - 1) / factor;
  Eigen::VectorXd out(n);
  for (Eigen::Index k = 0; k < n; ++k) out[k] = both[k * factor];
  return out;
}

}  // namespace panelbass::dsp
