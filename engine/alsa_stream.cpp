#include "engine/alsa_stream.h"

#include <algorithm>
#include <cerrno>
#include <cmath>

#include "engine/alsa_devices.h"
#include "engine/alsa_sample_format.h"

namespace panelbass::engine {

int alsa_timeout_ms(const AlsaOptions& o) noexcept {
  if (o.device_timeout.count() > 0) return static_cast<int>(o.device_timeout.count());
  const double buffer_ms = 1e3 * o.period.value * o.periods / o.rate.value;
  return std::max(200, static_cast<int>(std::ceil(8.0 * buffer_ms)));
}

bool AlsaBackend::recover(void* pcm_handle, int err, const char* where) noexcept {
  auto* pcm = static_cast<snd_pcm_t*>(pcm_handle);
  if (err == -EPIPE || err == -ESTRPIPE) {
    if (snd_pcm_recover(pcm, err, 1) >= 0) {
      // Recovered: count it and restart both streams in step, so the loop's delay is what it was.
      xruns_.fetch_add(1, std::memory_order_relaxed);
      chain_.metrics().record_xrun();
      set_error(where, err);
      return restart_streams();
    }
  }
  set_error(where, err);
  return false;
}

int AlsaBackend::read_period() noexcept {
  Devices& d = *devices_;
  const auto period = static_cast<snd_pcm_uframes_t>(options_.period.value);
  const std::size_t frame_bytes =
      static_cast<std::size_t>(options_.capture_channels) * static_cast<std::size_t>(snd_pcm_format_physical_width(d.capture_format) / 8);
  snd_pcm_uframes_t got = 0;
  while (got < period) {
    if (stop_.load(std::memory_order_relaxed)) return static_cast<int>(AlsaIo::lost);
    const snd_pcm_sframes_t n = snd_pcm_readi(d.capture, d.capture_raw.data() + got * frame_bytes, period - got);
    if (n >= 0) {
      got += static_cast<snd_pcm_uframes_t>(n);
      continue;
    }
    if (n == -EAGAIN) {
      const int w = snd_pcm_wait(d.capture, alsa_timeout_ms(options_));
      if (w == 0) {
        set_error("capture: no data within the device timeout (device lost?)", 0);
        return static_cast<int>(AlsaIo::lost);
      }
      if (w > 0) continue;
      return static_cast<int>(recover(d.capture, w, "capture wait") ? AlsaIo::restarted : AlsaIo::lost);
    }
    return static_cast<int>(recover(d.capture, static_cast<int>(n), "capture") ? AlsaIo::restarted : AlsaIo::lost);
  }
  const std::size_t ch = static_cast<std::size_t>(options_.capture_channels);
  const std::size_t bytes = static_cast<std::size_t>(snd_pcm_format_physical_width(d.capture_format) / 8);
  const auto take = [&](int channel, std::vector<double>& into) {
    for (std::size_t k = 0; k < period; ++k) {
      into[k] = read_sample(d.capture_raw.data() + (k * ch + static_cast<std::size_t>(channel)) * bytes, d.capture_format);
    }
  };
  if (options_.program_channel != kNoChannel) take(options_.program_channel, program_);
  if (options_.sensor_channel != kNoChannel) take(options_.sensor_channel, sensor_);
  if (options_.current_channel != kNoChannel) take(options_.current_channel, current_);
  if (options_.loopback_channel != kNoChannel) take(options_.loopback_channel, loopback_);
  return static_cast<int>(AlsaIo::ok);
}

int AlsaBackend::write_period() noexcept {
  Devices& d = *devices_;
  const auto period = static_cast<snd_pcm_uframes_t>(options_.period.value);
  const std::size_t ch = static_cast<std::size_t>(options_.playback_channels);
  const std::size_t bytes = static_cast<std::size_t>(snd_pcm_format_physical_width(d.playback_format) / 8);
  const std::size_t frame_bytes = ch * bytes;
  if (d.top_up) {
    // First period after a start: the playback began before the capture and has eaten into its
    // prefill by however long the start took; silence brings it back to a full buffer after this
    // write, so the loop's delay does not depend on that.
    d.top_up = false;
    const snd_pcm_sframes_t avail = snd_pcm_avail_update(d.playback);
    if (avail > static_cast<snd_pcm_sframes_t>(period)) {
      std::fill(d.playback_raw.begin(), d.playback_raw.end(), 0);
      snd_pcm_uframes_t left = static_cast<snd_pcm_uframes_t>(avail) - period;
      while (left > 0) {
        const snd_pcm_sframes_t n = snd_pcm_writei(d.playback, d.playback_raw.data(), std::min(left, period));
        if (n <= 0) break;
        left -= static_cast<snd_pcm_uframes_t>(n);
      }
    }
  }
  for (std::size_t k = 0; k < period; ++k) {
    for (std::size_t c = 0; c < ch; ++c) {
      const double x = static_cast<int>(c) == options_.drive_channel ? drive_[k] : 0.0;
      write_sample(d.playback_raw.data() + (k * ch + c) * bytes, d.playback_format, x);
    }
  }
  snd_pcm_uframes_t done = 0;
  while (done < period) {
    if (stop_.load(std::memory_order_relaxed)) return static_cast<int>(AlsaIo::lost);
    const snd_pcm_sframes_t n = snd_pcm_writei(d.playback, d.playback_raw.data() + done * frame_bytes, period - done);
    if (n >= 0) {
      done += static_cast<snd_pcm_uframes_t>(n);
      continue;
    }
    if (n == -EAGAIN) {
      const int w = snd_pcm_wait(d.playback, alsa_timeout_ms(options_));
      if (w == 0) {
        set_error("playback: no room within the device timeout (device lost?)", 0);
        return static_cast<int>(AlsaIo::lost);
      }
      if (w > 0) continue;
      return static_cast<int>(recover(d.playback, w, "playback wait") ? AlsaIo::restarted : AlsaIo::lost);
    }
    return static_cast<int>(recover(d.playback, static_cast<int>(n), "playback") ? AlsaIo::restarted : AlsaIo::lost);
  }
  return static_cast<int>(AlsaIo::ok);
}

void AlsaBackend::process_period() noexcept {
  // Program input from the player when no capture channel carries it; paused while a measurement plays.
  if (options_.program_channel == kNoChannel) {
    if (phase_ == MeasurePhase::measuring) {
      std::fill(program_.begin(), program_.end(), 0.0);
    } else {
      player_.fill(program_);  // zeros after a program played once has ended
    }
  }
  const bool sensed = options_.sensor_channel != kNoChannel;
  std::span<const double> model_program, model_drive;
  const auto run = [&](std::span<const std::span<const double>> in, std::span<double> out) {
    run_model_block(in, out);
    model_program = in[0];
    model_drive = out;
  };
  const std::span<const double> in[4] = {program_, sensor_, current_, loopback_};
  if (bridge_) {
    const auto channels = static_cast<std::size_t>(bridge_->options().input_channels);
    bridge_->process(std::span<const std::span<const double>>(in, channels), drive_, run);
  } else {
    run(std::span<const std::span<const double>>(in, 4), drive_);
  }
  // The chain's limiter keeps its drive in [−1, 1]; the interpolator's ringing may overshoot a hair.
  for (double& x : drive_) x = std::isfinite(x) ? std::clamp(x, -1.0, 1.0) : 0.0;
  if (options_.on_block) {
    options_.on_block(AlsaBlockView{period_index_, program_, sensed ? std::span<const double>(sensor_) : std::span<const double>{},
                                    drive_, model_program, model_drive});
  }
  ++period_index_;
  periods_.fetch_add(1, std::memory_order_relaxed);
}

void AlsaBackend::end_measurement(bool aborted) noexcept {
  if (measurement_ == nullptr) return;
  if (aborted) measurement_->abort();
  measurement_ = nullptr;
  phase_ = MeasurePhase::fading_in;
  ramp_ = 0;
}

void AlsaBackend::run_model_block(std::span<const std::span<const double>> in, std::span<double> out) noexcept {
  const std::size_t n = out.size();
  const bool sensed = options_.sensor_channel != kNoChannel;
  // A channel the bridge does not carry (or the card does not capture) reads as silence.
  const auto channel = [&](std::size_t c) {
    return c < in.size() ? in[c] : std::span<const double>(zeros_.data(), n);
  };
  const std::span<const double> program = in[0], sensor = channel(1), current = channel(2), loopback = channel(3);
  if (phase_ == MeasurePhase::idle) {
    if (Measurement* m = measurement_request_.exchange(nullptr, std::memory_order_acq_rel)) {
      if (m->begin()) {
        measurement_ = m;
        fade_ = m->fade_samples();
        ramp_ = 0;
        phase_ = MeasurePhase::fading_out;
        xruns_at_start_ = xruns_.load(std::memory_order_relaxed);
      }
    }
  }
  if (measurement_ != nullptr &&
      (measurement_->cancelled() || xruns_.load(std::memory_order_relaxed) != xruns_at_start_)) {
    // Cancelled, or an xrun broke the round trip's timing: the record would be misaligned.
    end_measurement(true);
  }
  if (phase_ == MeasurePhase::measuring) {
    std::fill(out.begin(), out.end(), 0.0);  // the chain is bypassed: nothing of it reaches the drive
  } else if (sensed) {
    // The chain with the sensor as it was captured for the same position in the period: a real loop
    // measures the drive only after the device's round trip, which the feedback stage is designed for.
    std::size_t k = 0;
    chain_.process_block(program, out, [&](double) noexcept { return sensor[k++]; });
  } else {
    chain_.process_block(program, out);
  }
  for (std::size_t k = 0; k < n && phase_ != MeasurePhase::idle; ++k) {
    switch (phase_) {
      case MeasurePhase::fading_out:
        out[k] *= 1.0 - static_cast<double>(ramp_) / static_cast<double>(fade_);
        if (++ramp_ >= fade_) phase_ = MeasurePhase::measuring;
        break;
      case MeasurePhase::measuring: {
        bool done = false;
        out[k] = measurement_->step(sensor[k], current[k], loopback[k], done);
        if (done) end_measurement(false);
        break;
      }
      case MeasurePhase::fading_in:
        out[k] *= static_cast<double>(ramp_) / static_cast<double>(fade_);
        if (++ramp_ >= fade_) phase_ = MeasurePhase::idle;
        break;
      case MeasurePhase::idle:
        break;
    }
  }
}

bool AlsaBackend::stream() noexcept {
  Devices& d = *devices_;
  while (!stop_.load(std::memory_order_relaxed)) {
    if (d.capture != nullptr) {
      const auto r = static_cast<AlsaIo>(read_period());
      if (r == AlsaIo::lost) return false;
      if (r == AlsaIo::restarted) continue;
    } else {
      // Playback only: paced by room for a period in the playback buffer.
      const snd_pcm_sframes_t avail = snd_pcm_avail_update(d.playback);
      if (avail < 0) {
        if (!recover(d.playback, static_cast<int>(avail), "playback")) return false;
        continue;
      }
      if (avail < options_.period.value) {
        const int w = snd_pcm_wait(d.playback, alsa_timeout_ms(options_));
        if (w == 0) {
          set_error("playback: no room within the device timeout (device lost?)", 0);
          return false;
        }
        if (w < 0 && !recover(d.playback, w, "playback wait")) return false;
        continue;
      }
    }
    process_period();
    if (d.playback != nullptr) {
      const auto w = static_cast<AlsaIo>(write_period());
      if (w == AlsaIo::lost) return false;
    }
  }
  return true;
}

}  // namespace panelbass::engine
