#pragma once
// The band-pass in front of a controller, as every verb that designs or runs one takes it.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dsp/biquad.h"
#include "models/control/lq_feedforward.h"

namespace panelbass::usecases {

/// A Butterworth band-pass: high-pass at low_hz (0: none) and low-pass at high_hz, each of `order`.
struct BandPass {
  double low_hz = 20.0;    ///< ≥ 0; 0 is a low-pass alone
  double high_hz = 1200.0;  ///< above low_hz, below the Nyquist frequency
  int order = 2;           ///< 1..16

  /// Throws RequestError naming "<field>.low_hz" etc. unless 0 ≤ low < high < fs/2 and 1 ≤ order ≤ 16.
  void check(const std::string& field, double fs) const;
  /// Its second-order sections at `fs` (check()ed first).
  std::vector<dsp::Biquad> sections(const std::string& field, double fs) const;
};

/// {"low_hz","high_hz","order"}.
nlohmann::json to_json(const BandPass& b);

/// The band-pass an LQ feedforward was designed behind, as its meta records it ("bandpass": [lo, hi],
/// "bandpass_order", as `design lq` writes them), else 20-1200 Hz of order 2 (the upper corner kept below 0.45·fs);
/// a meta entry out of range is ignored.
BandPass band_pass_of(const models::LqFeedforward& ff);

}  // namespace panelbass::usecases
