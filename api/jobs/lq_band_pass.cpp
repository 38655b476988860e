#include "api/jobs/lq_band_pass.h"

#include <algorithm>

#include "dsp/butterworth.h"

namespace panelbass::api {

LqBandPass lq_band_pass(const models::LqFeedforward& ff) {
  LqBandPass band;
  band.high_hz = std::min(1200.0, 0.45 * ff.fs);
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
  band.filter = dsp::butterworth_band(band.order, band.low_hz, band.high_hz, ff.fs);
  return band;
}

}  // namespace panelbass::api
