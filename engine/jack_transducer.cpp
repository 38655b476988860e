#include "engine/jack_transducer.h"

#include <jack/jack.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace panelbass::engine {

models::PlantConfig plant_at_rate(models::PlantConfig plant, double rate) {
  if (!std::isfinite(rate) || rate <= 0.0) throw std::invalid_argument("plant_at_rate: the rate must be finite and > 0");
  const double ratio = rate / plant.fs;
  plant.oversample = std::max(1, static_cast<int>(std::lround(plant.oversample / ratio)));
  plant.converters.delay_samples = static_cast<int>(std::lround(plant.converters.delay_samples * ratio));
  plant.sensor.delay_samples *= ratio;  // a microphone's acoustic delay, kept in time (fractions allowed)
  plant.sensor.noise_rms_V *= std::sqrt(ratio);
  plant.fs = rate;
  return plant;
}

namespace {

std::string jack_status_text(jack_status_t status) {
  std::string text;
  const auto add = [&](jack_status_t bit, const char* what) {
    if (status & bit) text += (text.empty() ? "" : ", ") + std::string(what);
  };
  add(JackServerFailed, "no JACK server to connect to");
  add(JackServerError, "communication error with the server");
  add(JackNameNotUnique, "the client name is taken");
  add(JackVersionError, "client/server protocol versions differ");
  add(JackInitFailure, "cannot initialise the client");
  add(JackShmFailure, "cannot access shared memory");
  return text.empty() ? "status " + std::to_string(static_cast<int>(status)) : text;
}

}  // namespace

JackTransducer::JackTransducer(JackTransducerOptions options) {
  // libjack prints its own diagnostics on stderr; the errors thrown here say what failed instead.
  jack_set_error_function([](const char*) {});
  jack_set_info_function([](const char*) {});
  jack_status_t status{};
  const int flags = JackNoStartServer | (options.server_name.empty() ? 0 : JackServerName);
  jack_client_t* client =
      options.server_name.empty()
          ? jack_client_open(options.client_name.c_str(), static_cast<jack_options_t>(flags), &status)
          : jack_client_open(options.client_name.c_str(), static_cast<jack_options_t>(flags), &status,
                             options.server_name.c_str());
  if (client == nullptr) {
    throw std::runtime_error("transducer: cannot open JACK client \"" + options.client_name + "\": " +
                             jack_status_text(status));
  }
  client_ = client;
  name_ = jack_get_client_name(client);
  rate_ = static_cast<double>(jack_get_sample_rate(client));
  try {
    transducer_ = std::make_unique<models::VirtualTransducer>(plant_at_rate(options.plant, rate_), options.noise_seed);
    if (!(options.record_window_s >= 0.0 && options.record_window_s <= 60.0)) {
      throw std::invalid_argument("transducer: the record window must be within [0, 60] s");
    }
    const auto window = static_cast<std::size_t>(std::lround(options.record_window_s * rate_));
    if (window > 0) {
      windows_.resize(3);
      for (int w = 0; w < 3; ++w) {
        windows_[w].drive.assign(window, 0.0);
        windows_[w].sensor.assign(window, 0.0);
        windows_[w].clean.assign(window, 0.0);
        free_.push(w);
      }
    }
    drive_ = jack_port_register(client, "drive", JACK_DEFAULT_AUDIO_TYPE, JackPortIsInput, 0);
    sensor_ = jack_port_register(client, "sensor", JACK_DEFAULT_AUDIO_TYPE, JackPortIsOutput, 0);
    current_ = jack_port_register(client, "current", JACK_DEFAULT_AUDIO_TYPE, JackPortIsOutput, 0);
    if (drive_ == nullptr || sensor_ == nullptr || current_ == nullptr) {
      throw std::runtime_error("transducer: cannot register the ports of JACK client \"" + name_ + "\"");
    }
    jack_set_process_callback(client, [](jack_nframes_t n, void* self) { return process(n, self); }, this);
    jack_on_shutdown(client, [](void* self) { on_shutdown(self); }, this);
    if (jack_activate(client) != 0) throw std::runtime_error("transducer: cannot activate JACK client \"" + name_ + "\"");
    for (const std::string& port : options.drive_from) connect(port, drive_port());
    for (const std::string& port : options.sensor_to) connect(sensor_port(), port);
    for (const std::string& port : options.current_to) connect(current_port(), port);
  } catch (...) {
    jack_client_close(client);
    client_ = nullptr;
    throw;
  }
}

JackTransducer::~JackTransducer() {
  if (client_ == nullptr) return;
  auto* client = static_cast<jack_client_t*>(client_);
  if (!shut_down()) jack_deactivate(client);
  jack_client_close(client);
}

void JackTransducer::connect(const std::string& from, const std::string& to) {
  const int err = jack_connect(static_cast<jack_client_t*>(client_), from.c_str(), to.c_str());
  if (err != 0 && err != EEXIST) throw std::runtime_error("transducer: cannot connect JACK port " + from + " to " + to);
}

int JackTransducer::process(std::uint32_t frames, void* self_ptr) noexcept {
  auto* self = static_cast<JackTransducer*>(self_ptr);
  const auto* drive = static_cast<const float*>(jack_port_get_buffer(static_cast<jack_port_t*>(self->drive_), frames));
  auto* sensor = static_cast<float*>(jack_port_get_buffer(static_cast<jack_port_t*>(self->sensor_), frames));
  auto* current = static_cast<float*>(jack_port_get_buffer(static_cast<jack_port_t*>(self->current_), frames));
  double peak = self->peak_drive_.load(std::memory_order_relaxed);
  for (std::uint32_t k = 0; k < frames; ++k) {
    const double u = std::isfinite(drive[k]) ? static_cast<double>(drive[k]) : 0.0;
    peak = std::max(peak, std::abs(u));
    const models::PlantSample s = self->transducer_->step(u);
    sensor[k] = static_cast<float>(s.y);
    current[k] = static_cast<float>(s.i);
    if (!self->windows_.empty()) self->record(u, s, self->frames_.load(std::memory_order_relaxed) + k);
  }
  self->peak_drive_.store(peak, std::memory_order_relaxed);
  self->frames_.fetch_add(frames, std::memory_order_relaxed);
  return 0;
}

void JackTransducer::record(double drive, const models::PlantSample& s, std::uint64_t frame) noexcept {
  if (filling_ < 0) {
    if (!free_.pop(filling_)) {
      filling_ = -1;
      dropped_frames_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    filled_ = 0;
    windows_[static_cast<std::size_t>(filling_)].first_frame = frame;
  }
  RecordedWindow& w = windows_[static_cast<std::size_t>(filling_)];
  w.drive[filled_] = drive;
  w.sensor[filled_] = s.y;
  w.clean[filled_] = s.y_clean;
  if (++filled_ == w.drive.size()) {
    full_.push(filling_);  // room: three windows in a queue of four
    filling_ = -1;
  }
}

const RecordedWindow* JackTransducer::next_window() {
  if (reading_ < 0 && !full_.pop(reading_)) reading_ = -1;
  return reading_ < 0 ? nullptr : &windows_[static_cast<std::size_t>(reading_)];
}

void JackTransducer::release_window() {
  if (reading_ < 0) return;
  free_.push(reading_);
  reading_ = -1;
}

void JackTransducer::on_shutdown(void* self) noexcept {
  static_cast<JackTransducer*>(self)->shut_down_.store(true, std::memory_order_relaxed);
}

}  // namespace panelbass::engine
