#include "api/jobs/lq_band_pass.h"

#include "dsp/butterworth.h"
#include "usecases/band_pass.h"

namespace panelbass::api {

LqBandPass lq_band_pass(const models::LqFeedforward& ff) {
  const usecases::BandPass b = usecases::band_pass_of(ff);
  return {b.low_hz, b.high_hz, b.order, dsp::butterworth_band(b.order, b.low_hz, b.high_hz, ff.fs)};
}

}  // namespace panelbass::api
