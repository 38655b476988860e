#include "engine/alsa_hw_params.h"

#include <cerrno>
#include <cmath>
#include <cstdio>

#include "engine/alsa_sample_format.h"

namespace panelbass::engine {

int configure_pcm(snd_pcm_t* pcm, const AlsaOptions& o, unsigned channels, snd_pcm_format_t& format,
                  snd_pcm_uframes_t& buffer_frames, char* what, std::size_t what_size) {
  const auto refused = [&](const char* text, int err) {
    std::snprintf(what, what_size, "%s", text);
    return err;
  };
  snd_pcm_hw_params_t* hw;
  snd_pcm_hw_params_alloca(&hw);
  int err = snd_pcm_hw_params_any(pcm, hw);
  if (err < 0) return refused("no hardware parameters", err);
  if ((err = snd_pcm_hw_params_set_access(pcm, hw, SND_PCM_ACCESS_RW_INTERLEAVED)) < 0) {
    return refused("interleaved read/write access refused", err);
  }
  err = -EINVAL;
  for (const snd_pcm_format_t f : kAlsaFormats) {
    if (snd_pcm_hw_params_test_format(pcm, hw, f) == 0) {
      format = f;
      err = snd_pcm_hw_params_set_format(pcm, hw, f);
      break;
    }
  }
  if (err < 0) return refused("none of FLOAT_LE, S32_LE, S16_LE is offered", err);
  unsigned ch_lo = 0, ch_hi = 0;
  snd_pcm_hw_params_get_channels_min(hw, &ch_lo);
  snd_pcm_hw_params_get_channels_max(hw, &ch_hi);
  if ((err = snd_pcm_hw_params_set_channels(pcm, hw, channels)) < 0) {
    std::snprintf(what, what_size, "%u channels refused (the device offers %u..%u)", channels, ch_lo, ch_hi);
    return err;
  }
  // What the device offers, for the message when it refuses (snprintf into the caller's buffer: no
  // allocation on this thread).
  unsigned lo = 0, hi = 0;
  int dir = 0;
  snd_pcm_hw_params_get_rate_min(hw, &lo, &dir);
  snd_pcm_hw_params_get_rate_max(hw, &hi, &dir);
  if ((err = snd_pcm_hw_params_set_rate(pcm, hw, static_cast<unsigned>(std::lround(o.rate.value)), 0)) < 0) {
    std::snprintf(what, what_size, "rate %ld Hz refused (the device offers %u..%u Hz)", std::lround(o.rate.value), lo, hi);
    return err;
  }
  snd_pcm_uframes_t frames_lo = 0, frames_hi = 0;
  snd_pcm_hw_params_get_period_size_min(hw, &frames_lo, &dir);
  snd_pcm_hw_params_get_period_size_max(hw, &frames_hi, &dir);
  if ((err = snd_pcm_hw_params_set_period_size(pcm, hw, static_cast<snd_pcm_uframes_t>(o.period.value), 0)) < 0) {
    std::snprintf(what, what_size, "period of %d frames refused (the device offers %lu..%lu)", o.period.value,
                  static_cast<unsigned long>(frames_lo), static_cast<unsigned long>(frames_hi));
    return err;
  }
  snd_pcm_hw_params_get_periods_min(hw, &lo, &dir);
  snd_pcm_hw_params_get_periods_max(hw, &hi, &dir);
  if ((err = snd_pcm_hw_params_set_periods(pcm, hw, static_cast<unsigned>(o.periods), 0)) < 0) {
    std::snprintf(what, what_size, "%d periods refused (the device offers %u..%u)", o.periods, lo, hi);
    return err;
  }
  if ((err = snd_pcm_hw_params(pcm, hw)) < 0) return refused("hardware parameters refused", err);
  snd_pcm_hw_params_get_buffer_size(hw, &buffer_frames);

  // Both streams start only when the backend says so (restart_streams), after the playback prefill.
  snd_pcm_sw_params_t* sw;
  snd_pcm_sw_params_alloca(&sw);
  snd_pcm_uframes_t boundary = 0;
  if ((err = snd_pcm_sw_params_current(pcm, sw)) < 0) return refused("no software parameters", err);
  snd_pcm_sw_params_get_boundary(sw, &boundary);
  if ((err = snd_pcm_sw_params_set_avail_min(pcm, sw, static_cast<snd_pcm_uframes_t>(o.period.value))) < 0 ||
      (err = snd_pcm_sw_params_set_start_threshold(pcm, sw, boundary)) < 0 ||
      (err = snd_pcm_sw_params(pcm, sw)) < 0) {
    return refused("software parameters refused", err);
  }
  return 0;
}

}  // namespace panelbass::engine
