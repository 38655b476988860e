#include "engine/alsa_backend.h"

#include <alsa/asoundlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "engine/realtime_thread.h"

namespace panelbass::engine {

namespace {

constexpr std::size_t kMaxSampleBytes = 4;  // FLOAT_LE, S32_LE, S16_LE

/// The sample formats the backend speaks, best first.
constexpr snd_pcm_format_t kFormats[] = {SND_PCM_FORMAT_FLOAT_LE, SND_PCM_FORMAT_S32_LE, SND_PCM_FORMAT_S16_LE};

double read_sample(const unsigned char* p, snd_pcm_format_t format) noexcept {
  switch (format) {
    case SND_PCM_FORMAT_FLOAT_LE: {
      float x;
      std::memcpy(&x, p, sizeof x);
      return x;
    }
    case SND_PCM_FORMAT_S32_LE: {
      std::int32_t x;
      std::memcpy(&x, p, sizeof x);
      return x / 2147483648.0;
    }
    default: {
      std::int16_t x;
      std::memcpy(&x, p, sizeof x);
      return x / 32768.0;
    }
  }
}

void write_sample(unsigned char* p, snd_pcm_format_t format, double x) noexcept {
  switch (format) {
    case SND_PCM_FORMAT_FLOAT_LE: {
      const auto y = static_cast<float>(x);
      std::memcpy(p, &y, sizeof y);
      return;
    }
    case SND_PCM_FORMAT_S32_LE: {
      const auto y = static_cast<std::int32_t>(std::lrint(std::clamp(x, -1.0, 1.0) * 2147483647.0));
      std::memcpy(p, &y, sizeof y);
      return;
    }
    default: {
      const auto y = static_cast<std::int16_t>(std::lrint(std::clamp(x, -1.0, 1.0) * 32767.0));
      std::memcpy(p, &y, sizeof y);
      return;
    }
  }
}

std::string alsa_message(const std::string& what, int err) { return what + ": " + snd_strerror(err); }

}  // namespace

/// The PCMs, the configuration they are opened from and their raw interleaved buffers.
struct AlsaBackend::Devices {
  snd_config_t* config = nullptr;  // parsed config_text (null: the system's configuration)
  snd_pcm_t* playback = nullptr;
  snd_pcm_t* capture = nullptr;
  snd_pcm_format_t playback_format = SND_PCM_FORMAT_FLOAT_LE;
  snd_pcm_format_t capture_format = SND_PCM_FORMAT_FLOAT_LE;
  snd_pcm_uframes_t buffer_frames = 0;  // playback buffer, as the device granted it
  std::vector<unsigned char> playback_raw, capture_raw;
  bool top_up = false;  // the first period after a (re)start brings the playback fill to its target

  ~Devices() {
    if (config != nullptr) snd_config_delete(config);
  }
};

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

void checked(const AlsaOptions& o) {
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
  } else {
    if (o.program_channel != kNoChannel) fail("program_channel is set but no capture device is named");
    if (o.sensor_channel != kNoChannel) fail("sensor_channel is set but no capture device is named");
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
}

bool same_rate(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(a, b); }

}  // namespace

AlsaBackend::AlsaBackend(Chain& chain, AlsaOptions options)
    : chain_(chain), options_(std::move(options)), devices_(std::make_unique<Devices>()) {
  checked(options_);
  const ProcessSpec& spec = chain_.options().spec;
  const auto period = static_cast<std::size_t>(options_.period.value);
  if (!same_rate(options_.rate.value, spec.fs)) {
    RateBridgeOptions bridge;
    bridge.device_rate = options_.rate;
    bridge.model_rate = Hertz{spec.fs};
    bridge.max_period = options_.period;
    bridge.input_channels = options_.sensor_channel != kNoChannel ? 2 : 1;
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

bool AlsaBackend::sleep_unless_stopped(std::chrono::milliseconds wait) noexcept {
  const auto until = std::chrono::steady_clock::now() + wait;
  while (!stop_.load(std::memory_order_relaxed)) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= until) return true;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(until - now, std::chrono::milliseconds(10)));
  }
  return false;
}

namespace {

/// Configures `pcm` for `channels` interleaved channels at the options' rate, period and period count;
/// picks the first format of kFormats it takes. Returns 0 or a negative errno with `what` (a buffer of
/// `what_size` characters) saying what was refused.
int configure(snd_pcm_t* pcm, const AlsaOptions& o, unsigned channels, snd_pcm_format_t& format,
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
  for (const snd_pcm_format_t f : kFormats) {
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

}  // namespace

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
    if ((err = configure(pcm, options_, channels, format, frames, what, sizeof what)) < 0) {
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

namespace {

/// How a device call ended.
enum class Io { ok, restarted, lost };

int timeout_ms(const AlsaOptions& o) {
  if (o.device_timeout.count() > 0) return static_cast<int>(o.device_timeout.count());
  const double buffer_ms = 1e3 * o.period.value * o.periods / o.rate.value;
  return std::max(200, static_cast<int>(std::ceil(8.0 * buffer_ms)));
}

}  // namespace

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
    if (stop_.load(std::memory_order_relaxed)) return static_cast<int>(Io::lost);
    const snd_pcm_sframes_t n = snd_pcm_readi(d.capture, d.capture_raw.data() + got * frame_bytes, period - got);
    if (n >= 0) {
      got += static_cast<snd_pcm_uframes_t>(n);
      continue;
    }
    if (n == -EAGAIN) {
      const int w = snd_pcm_wait(d.capture, timeout_ms(options_));
      if (w == 0) {
        set_error("capture: no data within the device timeout (device lost?)", 0);
        return static_cast<int>(Io::lost);
      }
      if (w > 0) continue;
      return static_cast<int>(recover(d.capture, w, "capture wait") ? Io::restarted : Io::lost);
    }
    return static_cast<int>(recover(d.capture, static_cast<int>(n), "capture") ? Io::restarted : Io::lost);
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
  return static_cast<int>(Io::ok);
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
    if (stop_.load(std::memory_order_relaxed)) return static_cast<int>(Io::lost);
    const snd_pcm_sframes_t n = snd_pcm_writei(d.playback, d.playback_raw.data() + done * frame_bytes, period - done);
    if (n >= 0) {
      done += static_cast<snd_pcm_uframes_t>(n);
      continue;
    }
    if (n == -EAGAIN) {
      const int w = snd_pcm_wait(d.playback, timeout_ms(options_));
      if (w == 0) {
        set_error("playback: no room within the device timeout (device lost?)", 0);
        return static_cast<int>(Io::lost);
      }
      if (w > 0) continue;
      return static_cast<int>(recover(d.playback, w, "playback wait") ? Io::restarted : Io::lost);
    }
    return static_cast<int>(recover(d.playback, static_cast<int>(n), "playback") ? Io::restarted : Io::lost);
  }
  return static_cast<int>(Io::ok);
}

void AlsaBackend::process_period() noexcept {
  // Program input from the vector when no capture channel carries it.
  if (options_.program_channel == kNoChannel) {
    const std::vector<double>& p = options_.program;
    for (double& x : program_) {
      if (p.empty() || (!options_.loop_program && program_pos_ >= p.size())) {
        x = 0.0;
        continue;
      }
      x = p[program_pos_ % p.size()];
      program_pos_ = options_.loop_program ? (program_pos_ + 1) % p.size() : program_pos_ + 1;
    }
  }
  const bool sensed = options_.sensor_channel != kNoChannel;
  std::span<const double> model_program, model_drive;
  // The chain with the sensor as it was captured for the same position in the period: a real loop
  // measures the drive only after the device's round trip, which the feedback stage is designed for.
  const auto run_chain = [&](std::span<const double> program, std::span<const double> sensor, std::span<double> drive) {
    if (sensed) {
      std::size_t k = 0;
      chain_.process_block(program, drive, [&](double) noexcept { return sensor[k++]; });
    } else {
      chain_.process_block(program, drive);
    }
    model_program = program;
    model_drive = drive;
  };
  if (bridge_) {
    const std::span<const double> in[2] = {program_, sensor_};
    bridge_->process(std::span<const std::span<const double>>(in, sensed ? 2 : 1), drive_,
                     [&](std::span<const std::span<const double>> model_in, std::span<double> model_out) {
                       run_chain(model_in[0], sensed ? model_in[1] : std::span<const double>{}, model_out);
                     });
  } else {
    run_chain(program_, sensor_, drive_);
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

bool AlsaBackend::stream() noexcept {
  Devices& d = *devices_;
  while (!stop_.load(std::memory_order_relaxed)) {
    if (d.capture != nullptr) {
      const auto r = static_cast<Io>(read_period());
      if (r == Io::lost) return false;
      if (r == Io::restarted) continue;
    } else {
      // Playback only: paced by room for a period in the playback buffer.
      const snd_pcm_sframes_t avail = snd_pcm_avail_update(d.playback);
      if (avail < 0) {
        if (!recover(d.playback, static_cast<int>(avail), "playback")) return false;
        continue;
      }
      if (avail < options_.period.value) {
        const int w = snd_pcm_wait(d.playback, timeout_ms(options_));
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
      const auto w = static_cast<Io>(write_period());
      if (w == Io::lost) return false;
    }
  }
  return true;
}

void AlsaBackend::run() noexcept {
  realtime_.store(make_this_thread_realtime(options_.realtime_priority), std::memory_order_relaxed);
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
    if (stopped || stop_.load(std::memory_order_relaxed)) break;
    losses_.fetch_add(1, std::memory_order_relaxed);
    state_.store(AlsaState::reopening, std::memory_order_relaxed);
    if (!sleep_unless_stopped(wait)) break;
  }
  close_devices();
  state_.store(AlsaState::stopped, std::memory_order_relaxed);
}

}  // namespace panelbass::engine
