#include "engine/alsa_devices.h"

#include <algorithm>
#include <cerrno>
#include <thread>

#include "engine/alsa_hw_params.h"
#include "engine/realtime_thread.h"

namespace panelbass::engine {

bool AlsaBackend::sleep_unless_stopped(std::chrono::milliseconds wait) noexcept {
  const auto until = std::chrono::steady_clock::now() + wait;
  while (!stop_.load(std::memory_order_relaxed)) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= until) return true;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(until - now, std::chrono::milliseconds(10)));
  }
  return false;
}

bool AlsaBackend::open_devices() noexcept {
  Devices& d = *devices_;
  const auto open_one = [&](const std::string& name, snd_pcm_stream_t stream, snd_pcm_t*& pcm, unsigned channels,
                            snd_pcm_format_t& format, snd_pcm_uframes_t& buffer) {
    const char* prefix = stream == SND_PCM_STREAM_PLAYBACK ? "playback " : "capture ";
    int err = d.config != nullptr
                  ? snd_pcm_open_lconf(&pcm, name.c_str(), stream, SND_PCM_NONBLOCK, d.config)
                  : snd_pcm_open(&pcm, name.c_str(), stream, SND_PCM_NONBLOCK);
    char where[160];
    const auto describe = [&](const char* what) {
      std::size_t n = 0;
      for (const char* s : {prefix, name.c_str(), ": ", what}) {
        for (; *s != '\0' && n + 1 < sizeof where; ++s) where[n++] = *s;
      }
      where[n] = '\0';
    };
    if (err < 0) {
      pcm = nullptr;
      describe("cannot open");
      set_error(where, err);
      return false;
    }
    char what[120] = "";
    snd_pcm_uframes_t frames = 0;
    if ((err = configure_pcm(pcm, options_, channels, format, frames, what, sizeof what)) < 0) {
      describe(what);
      set_error(where, err);
      return false;
    }
    buffer = frames;
    return true;
  };
  snd_pcm_uframes_t capture_buffer = 0;
  if (!options_.playback_device.empty() &&
      !open_one(options_.playback_device, SND_PCM_STREAM_PLAYBACK, d.playback,
                static_cast<unsigned>(options_.playback_channels), d.playback_format, d.buffer_frames)) {
    return false;
  }
  if (!options_.capture_device.empty() &&
      !open_one(options_.capture_device, SND_PCM_STREAM_CAPTURE, d.capture,
                static_cast<unsigned>(options_.capture_channels), d.capture_format, capture_buffer)) {
    return false;
  }
  return restart_streams();
}

void AlsaBackend::close_devices() noexcept {
  Devices& d = *devices_;
  if (d.capture != nullptr) snd_pcm_close(d.capture);
  if (d.playback != nullptr) snd_pcm_close(d.playback);
  d.capture = d.playback = nullptr;
}

bool AlsaBackend::restart_streams() noexcept {
  Devices& d = *devices_;
  for (snd_pcm_t* pcm : {d.playback, d.capture}) {
    if (pcm == nullptr) continue;
    snd_pcm_drop(pcm);
    if (const int err = snd_pcm_prepare(pcm); err < 0) {
      set_error("prepare", err);
      return false;
    }
  }
  if (d.playback != nullptr) {
    // A full buffer of silence, then start: the playback runs ahead of the capture by its buffer.
    std::fill(d.playback_raw.begin(), d.playback_raw.end(), 0);
    snd_pcm_uframes_t left = d.buffer_frames;
    const auto period = static_cast<snd_pcm_uframes_t>(options_.period.value);
    while (left > 0) {
      const snd_pcm_sframes_t n = snd_pcm_writei(d.playback, d.playback_raw.data(), std::min(left, period));
      if (n <= 0) {
        set_error("playback prefill", n < 0 ? static_cast<int>(n) : -EIO);
        return false;
      }
      left -= static_cast<snd_pcm_uframes_t>(n);
    }
    if (const int err = snd_pcm_start(d.playback); err < 0) {
      set_error("playback start", err);
      return false;
    }
  }
  if (d.capture != nullptr) {
    if (const int err = snd_pcm_start(d.capture); err < 0) {
      set_error("capture start", err);
      return false;
    }
  }
  d.top_up = d.playback != nullptr && d.capture != nullptr;
  return true;
}

void AlsaBackend::run() noexcept {
  // Before any device is opened: scheduling and the memory lock are asked for once, never inside a period.
  const RealtimeGrant grant = make_this_thread_realtime_and_locked(options_.realtime_priority);
  realtime_.store(grant.priority, std::memory_order_relaxed);
  memory_locked_.store(grant.memory_locked, std::memory_order_relaxed);
  auto wait = options_.reopen_min;
  while (!stop_.load(std::memory_order_relaxed)) {
    state_.store(AlsaState::opening, std::memory_order_relaxed);
    if (!open_devices()) {
      close_devices();
      failed_opens_.fetch_add(1, std::memory_order_relaxed);
      state_.store(AlsaState::reopening, std::memory_order_relaxed);
      if (!sleep_unless_stopped(wait)) break;
      wait = std::min(wait * 2, options_.reopen_max);
      continue;
    }
    opens_.fetch_add(1, std::memory_order_relaxed);
    if (bridge_) bridge_->reset();  // nothing from before the (re)open comes out
    wait = options_.reopen_min;
    state_.store(AlsaState::running, std::memory_order_relaxed);
    const bool stopped = stream();
    close_devices();
    end_measurement(true);  // a device lost (or stopped) mid-measurement leaves it incomplete
    phase_ = MeasurePhase::idle;
    if (stopped || stop_.load(std::memory_order_relaxed)) break;
    losses_.fetch_add(1, std::memory_order_relaxed);
    state_.store(AlsaState::reopening, std::memory_order_relaxed);
    if (!sleep_unless_stopped(wait)) break;
  }
  close_devices();
  end_measurement(true);
  phase_ = MeasurePhase::idle;
  if (Measurement* m = measurement_request_.exchange(nullptr, std::memory_order_acq_rel)) m->abort();
  state_.store(AlsaState::stopped, std::memory_order_relaxed);
}

}  // namespace panelbass::engine
