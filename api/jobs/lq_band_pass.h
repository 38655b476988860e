#pragma once
// The band-pass an LQ feedforward controller was designed behind, as its file's meta records it.

#include <vector>

#include "dsp/biquad.h"
#include "models/control/lq_feedforward.h"

namespace panelbass::api {

/// A Butterworth band-pass: its corners (Hz), its order and its sections.
struct LqBandPass {
  double low_hz = 20.0;             ///< lower corner
  double high_hz = 1200.0;          ///< upper corner
  int order = 2;                    ///< Butterworth order
  std::vector<dsp::Biquad> filter;  ///< the sections at the controller's rate
};

/// The band-pass of `ff`'s meta ("bandpass": [lo, hi], "bandpass_order", as `design lq` writes them), else
/// 20–1200 Hz of order 2 (the upper corner kept below 0.45·fs); a meta entry out of range is ignored.
LqBandPass lq_band_pass(const models::LqFeedforward& ff);

}  // namespace panelbass::api
