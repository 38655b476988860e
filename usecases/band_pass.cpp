#include "usecases/band_pass.h"

#include <cmath>

#include "dsp/butterworth.h"
#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

void BandPass::check(const std::string& field, double fs) const {
  using models::number_text;
  if (!(std::isfinite(low_hz) && low_hz >= 0.0)) {
    throw RequestError(field + ".low_hz", "must be ≥ 0 Hz, got " + number_text(low_hz));
  }
  if (!(std::isfinite(high_hz) && high_hz > low_hz)) {
    throw RequestError(field + ".high_hz", "must be above low_hz (" + number_text(low_hz) + " Hz), got " + number_text(high_hz));
  }
  if (!(high_hz < fs / 2.0)) {
    throw RequestError(field + ".high_hz", number_text(high_hz) + " Hz is not below the model's Nyquist frequency " +
                                               number_text(fs / 2.0) + " Hz");
  }
  if (order < 1 || order > 16) throw RequestError(field + ".order", "must be within 1..16, got " + std::to_string(order));
}

std::vector<dsp::Biquad> BandPass::sections(const std::string& field, double fs) const {
  check(field, fs);
  return dsp::butterworth_band(order, low_hz, high_hz, fs);
}

nlohmann::json to_json(const BandPass& b) { return {{"low_hz", b.low_hz}, {"high_hz", b.high_hz}, {"order", b.order}}; }

}  // namespace panelbass::usecases
