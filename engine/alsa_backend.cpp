#include "engine/alsa_backend.h"

#include <alsa/asoundlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "dsp/sample_rate.h"
#include "engine/alsa_devices.h"
#include "engine/alsa_sample_format.h"

namespace panelbass::engine {

namespace {

std::string alsa_message(const std::string& what, int err) { return what + ": " + snd_strerror(err); }

}  // namespace

const char* alsa_state_name(AlsaState state) {
  switch (state) {
    case AlsaState::stopped:
      return "stopped";
    case AlsaState::opening:
      return "opening";
    case AlsaState::running:
      return "running";
    case AlsaState::reopening:
      return "reopening";
  }
  return "?";
}

namespace {

void check_channel(const char* name, int channel, int channels, bool allow_none) {
  if (channel == kNoChannel && allow_none) return;
  if (channel < 0 || channel >= channels) {
    throw std::invalid_argument("alsa backend: " + std::string(name) + " must be within [0, " +
                                std::to_string(channels - 1) + "]" + (allow_none ? " or none" : "") + ", got " +
                                std::to_string(channel));
  }
}

AlsaOptions checked(AlsaOptions o) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("alsa backend: " + what); };
  const bool playback = !o.playback_device.empty(), capture = !o.capture_device.empty();
  if (!playback && !capture) fail("neither a playback nor a capture device is named");
  if (!(std::isfinite(o.rate.value) && o.rate.value >= 1.0 && o.rate.value == std::round(o.rate.value))) {
    fail("rate must be a whole number of Hz >= 1, got " + std::to_string(o.rate.value));
  }
  if (o.period.value < 1 || o.period.value > 65536) fail("period must be within [1, 65536] frames, got " + std::to_string(o.period.value));
  if (o.periods < 2 || o.periods > 64) fail("periods must be within [2, 64], got " + std::to_string(o.periods));
  if (playback) {
    if (o.playback_channels < 1) fail("playback_channels must be >= 1, got " + std::to_string(o.playback_channels));
    check_channel("drive_channel", o.drive_channel, o.playback_channels, false);
  }
  if (capture) {
    if (o.capture_channels < 1) fail("capture_channels must be >= 1, got " + std::to_string(o.capture_channels));
    check_channel("program_channel", o.program_channel, o.capture_channels, true);
    check_channel("sensor_channel", o.sensor_channel, o.capture_channels, true);
    check_channel("current_channel", o.current_channel, o.capture_channels, true);
    check_channel("loopback_channel", o.loopback_channel, o.capture_channels, true);
  } else {
    if (o.program_channel != kNoChannel) fail("program_channel is set but no capture device is named");
    if (o.sensor_channel != kNoChannel) fail("sensor_channel is set but no capture device is named");
    if (o.current_channel != kNoChannel) fail("current_channel is set but no capture device is named");
    if (o.loopback_channel != kNoChannel) fail("loopback_channel is set but no capture device is named");
  }
  for (const double x : o.program) {
    if (!std::isfinite(x)) fail("the program has a non-finite sample");
  }
  if (o.reopen_min.count() < 1 || o.reopen_max < o.reopen_min) {
    fail("reopen back-off must satisfy 1 ms <= reopen_min <= reopen_max, got " + std::to_string(o.reopen_min.count()) +
         " and " + std::to_string(o.reopen_max.count()) + " ms");
  }
  if (o.device_timeout.count() < 0) fail("device_timeout must be >= 0 ms");
  if (o.realtime_priority < 0 || o.realtime_priority > 99) {
    fail("realtime_priority must be within [0, 99], got " + std::to_string(o.realtime_priority));
  }
  if (!(o.program_fade_s >= 0.0 && o.program_fade_s <= 10.0)) fail("program_fade_s must be within [0, 10] s");
  return o;
}

}  // namespace

AlsaBackend::AlsaBackend(Chain& chain, AlsaOptions options)
    : chain_(chain),
      options_(checked(std::move(options))),
      player_(std::move(options_.program), options_.loop_program,
              static_cast<std::size_t>(std::lround(options_.program_fade_s * options_.rate.value))),
      devices_(std::make_unique<Devices>()) {
  const ProcessSpec& spec = chain_.options().spec;
  const auto period = static_cast<std::size_t>(options_.period.value);
  if (!dsp::same_rate(options_.rate.value, spec.fs)) {
    RateBridgeOptions bridge;
    bridge.device_rate = options_.rate;
    bridge.model_rate = Hertz{spec.fs};
    bridge.max_period = options_.period;
    // Program, then the sensor, the current and the loopback as far as the last one captured.
    bridge.input_channels = options_.loopback_channel != kNoChannel  ? 4
                            : options_.current_channel != kNoChannel ? 3
                            : options_.sensor_channel != kNoChannel  ? 2
                                                                     : 1;
    bridge.quality = options_.quality;
    bridge_ = std::make_unique<RateBridge>(bridge);
    if (bridge_->max_model_block() > static_cast<std::size_t>(spec.max_block)) {
      throw std::invalid_argument("alsa backend: a " + std::to_string(period) + "-frame period at " +
                                  std::to_string(options_.rate.value) + " Hz yields up to " +
                                  std::to_string(bridge_->max_model_block()) + " samples at " +
                                  std::to_string(spec.fs) + " Hz, more than the chain's max_block " +
                                  std::to_string(spec.max_block));
    }
  } else if (period > static_cast<std::size_t>(spec.max_block)) {
    throw std::invalid_argument("alsa backend: period " + std::to_string(period) + " exceeds the chain's max_block " +
                                std::to_string(spec.max_block));
  }
  if (!options_.config_text.empty()) {
    snd_config_t* top = nullptr;
    snd_input_t* in = nullptr;
    int err = snd_config_top(&top);
    if (err >= 0) err = snd_input_buffer_open(&in, options_.config_text.data(), static_cast<ssize_t>(options_.config_text.size()));
    if (err >= 0) err = snd_config_load(top, in);
    if (in != nullptr) snd_input_close(in);
    if (err < 0) {
      if (top != nullptr) snd_config_delete(top);
      throw std::invalid_argument(alsa_message("alsa backend: config_text does not parse", err));
    }
    devices_->config = top;
  }
  program_.assign(period, 0.0);
  sensor_.assign(period, 0.0);
  current_.assign(period, 0.0);
  loopback_.assign(period, 0.0);
  zeros_.assign(std::max<std::size_t>(period, static_cast<std::size_t>(spec.max_block)), 0.0);
  drive_.assign(period, 0.0);
  devices_->playback_raw.assign(period * static_cast<std::size_t>(options_.playback_channels) * kMaxSampleBytes, 0);
  devices_->capture_raw.assign(period * static_cast<std::size_t>(options_.capture_channels) * kMaxSampleBytes, 0);
  set_error_text("");
}

AlsaBackend::~AlsaBackend() { stop(); }

void AlsaBackend::start() {
  if (thread_.joinable()) throw std::logic_error("alsa backend: already running");
  stop_.store(false, std::memory_order_relaxed);
  state_.store(AlsaState::opening, std::memory_order_relaxed);
  thread_ = std::thread([this] { run(); });
}

void AlsaBackend::stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
  state_.store(AlsaState::stopped, std::memory_order_relaxed);
}

Measurement::State AlsaBackend::measure(Measurement& m, std::chrono::milliseconds timeout) {
  const std::lock_guard turn(measuring_);
  if (m.state() != Measurement::State::pending) throw std::logic_error("alsa backend: a measurement is played once");
  const auto until = std::chrono::steady_clock::now() + timeout;
  measurement_request_.store(&m, std::memory_order_release);
  for (;;) {
    const Measurement::State s = m.state();
    if (s == Measurement::State::finished || s == Measurement::State::aborted) return s;
    if (std::chrono::steady_clock::now() >= until || !thread_.joinable()) {
      // Withdraw it if the device thread has not taken it; else have it abandoned, and wait for that.
      Measurement* expected = &m;
      if (measurement_request_.compare_exchange_strong(expected, nullptr, std::memory_order_acq_rel)) {
        m.cancel();
        m.abort();
        return Measurement::State::aborted;
      }
      m.cancel();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

RateBridgeLatency AlsaBackend::resampling_latency() const { return bridge_ ? bridge_->latency() : RateBridgeLatency{}; }

AlsaStatus AlsaBackend::status() const {
  AlsaStatus s;
  s.state = state_.load(std::memory_order_relaxed);
  s.opens = opens_.load(std::memory_order_relaxed);
  s.failed_opens = failed_opens_.load(std::memory_order_relaxed);
  s.losses = losses_.load(std::memory_order_relaxed);
  s.xruns = xruns_.load(std::memory_order_relaxed);
  s.periods = periods_.load(std::memory_order_relaxed);
  s.realtime = realtime_.load(std::memory_order_relaxed);
  s.memory_locked = memory_locked_.load(std::memory_order_relaxed);
  // Seqlock read: retry while the writer is inside (odd) or has been inside meanwhile (changed).
  for (;;) {
    const std::uint32_t before = error_seq_.load(std::memory_order_acquire);
    if (before & 1u) {
      std::this_thread::yield();
      continue;
    }
    for (std::size_t i = 0; i < s.last_error.size(); ++i) s.last_error[i] = error_text_[i].load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (error_seq_.load(std::memory_order_relaxed) == before) break;
  }
  s.last_error.back() = '\0';
  return s;
}

void AlsaBackend::set_error_text(const char* text) noexcept {
  const std::uint32_t seq = error_seq_.load(std::memory_order_relaxed);
  error_seq_.store(seq + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  std::size_t i = 0;
  for (; i + 1 < error_text_.size() && text[i] != '\0'; ++i) error_text_[i].store(text[i], std::memory_order_relaxed);
  for (; i < error_text_.size(); ++i) error_text_[i].store('\0', std::memory_order_relaxed);
  error_seq_.store(seq + 2, std::memory_order_release);
}

void AlsaBackend::set_error(const char* where, int err) noexcept {
  // No formatting library on the device thread: "where: ALSA's text" by hand into a stack buffer.
  char text[160];
  std::size_t n = 0;
  const auto append = [&](const char* s) {
    for (; *s != '\0' && n + 1 < sizeof text; ++s) text[n++] = *s;
  };
  append(where);
  if (err != 0) {
    append(": ");
    append(snd_strerror(err));
  }
  text[n] = '\0';
  set_error_text(text);
}

}  // namespace panelbass::engine
