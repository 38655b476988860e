#include "usecases/band_pass.h"

#include <algorithm>
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

BandPass band_pass_of(const models::LqFeedforward& ff) {
  BandPass band;
  band.high_hz = std::min(band.high_hz, 0.45 * ff.fs);
  const nlohmann::json& meta = ff.meta;
  if (meta.is_object() && meta.contains("bandpass") && meta["bandpass"].is_array() && meta["bandpass"].size() == 2 &&
      meta["bandpass"][0].is_number() && meta["bandpass"][1].is_number()) {
    const double l = meta["bandpass"][0].get<double>(), h = meta["bandpass"][1].get<double>();
    if (l >= 0.0 && h > l && h < ff.fs / 2.0) {
      band.low_hz = l;
      band.high_hz = h;
    }
  }
  if (meta.is_object() && meta.contains("bandpass_order") && meta["bandpass_order"].is_number_integer()) {
    const int o = meta["bandpass_order"].get<int>();
    if (o >= 1 && o <= 16) band.order = o;
  }
  return band;
}

}  // namespace panelbass::usecases
