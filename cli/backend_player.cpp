#include "cli/backend_player.h"

#include <chrono>
#include <stdexcept>
#include <thread>

#include "models/plant/converter_loop.h"
#include "models/plant/plant_presets.h"
#include "models/io/number_text.h"
#include "models/plant/virtual_transducer.h"
#include "usecases/card_measurement.h"

namespace panelbass::cli {
namespace {

// How long a card may take to stream after it is started.
constexpr std::chrono::seconds kCardStart{5};

}  // namespace

void add_backend_options(CLI::App* cmd, BackendOptions& o) {
  cmd->add_option("--backend", o.backend, "virtual: the simulated transducer; alsa: a sound card (calibrated measurement)")
      ->check(CLI::IsMember({"virtual", "alsa"}))
      ->capture_default_str();
  cmd->add_option("--plant", o.plant, "The virtual transducer: preset or plant JSON file (on a card: its rate is the chain's)")
      ->capture_default_str();
  cmd->add_flag("--quiet-sensor", o.quiet_sensor, "Virtual backend: without the plant's sensor noise");
  cmd->add_option("--safe-level", o.safe_level, "Sound card: the largest drive peak the transducer may be played")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  add_alsa_options(cmd, o.alsa);
}

BackendPlayer::BackendPlayer(const BackendOptions& o, std::uint64_t seed)
    : options_(o), plant_(models::plant_from_name_or_file(o.plant)), seed_(seed) {
  if (o.quiet_sensor) plant_ = models::without_sensor_noise(plant_);
  if (o.backend != "alsa") return;
  engine::AlsaOptions card = alsa_options_of(o.alsa);
  if (const std::optional<std::string> why = usecases::card_cannot_measure(card)) {
    throw std::invalid_argument("--backend alsa: " + *why);
  }
  card.loop_program = false;  // silence between measurements
  engine::ChainConfig config;
  config.fs = plant_.fs;
  chain_ = engine::make_chain(config);
  card_ = std::make_unique<engine::AlsaBackend>(*chain_, std::move(card));
  card_->start();
  const auto give_up = std::chrono::steady_clock::now() + kCardStart;
  while (card_->status().state != engine::AlsaState::running && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (card_->status().state != engine::AlsaState::running) {
    const std::string error = card_->status().last_error.data();
    card_->stop();
    throw std::runtime_error("--backend alsa: the devices did not stream within 5 s (playback \"" + o.alsa.playback +
                             "\", capture \"" + o.alsa.capture + "\"): " + error);
  }
}

BackendPlayer::~BackendPlayer() {
  if (card_) card_->stop();
}

double BackendPlayer::safe_level() const { return card_ ? options_.safe_level : 1.0; }

usecases::PlayFunction BackendPlayer::play() {
  if (card_) {
    return [this](const Eigen::VectorXd& drive) {
      return usecases::measure_through_card(*card_, card_->options(), {plant_.fs, options_.safe_level, options_.fade_seconds},
                                            drive);
    };
  }
  // Each play a new stretch of the plant's sensor noise; the drive through its converters alone as the loopback
  // (unless left out).
  return [this](const Eigen::VectorXd& drive) {
    models::PlantRecord r = models::simulate(plant_, drive, seed_++);
    usecases::Playback p;
    p.sensor = std::move(r.y);
    p.current = std::move(r.i);
    if (options_.virtual_loopback) p.loopback = models::converters_alone(plant_, drive);
    return p;
  };
}

engine::ChainConfig BackendPlayer::chain(const std::string& path) const {
  if (path.empty()) {
    engine::ChainConfig c;
    c.fs = fs();
    return c;
  }
  engine::ChainConfig c = engine::load_chain_file(path);
  if (c.fs != fs()) {
    throw std::invalid_argument(path + ": the chain runs at " + models::number_text(c.fs) + " Hz, the plant at " +
                                models::number_text(fs()) + " Hz");
  }
  return c;
}

}  // namespace panelbass::cli
