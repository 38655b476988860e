#pragma once
// The transducer a CLI verb plays through (`measure`, `verify`, `tune`): --backend virtual, a plant preset or file simulated
// (each play a new stretch of its sensor noise), or --backend alsa, a sound card measured by the card measurement
// protocol (usecases/card_measurement.h) as the server's jobs measure through it. The plant sets the chain's rate on
// either backend.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "cli/alsa_options.h"
#include "engine/alsa_backend.h"
#include "engine/chain.h"
#include "engine/chain_file.h"
#include "models/plant/plant_config.h"
#include "usecases/transducer_port.h"

namespace panelbass::cli {

/// The backend options as given on the command line.
struct BackendOptions {
  std::string backend = "virtual";   ///< "virtual" or "alsa"
  std::string plant = "panel-exciter";  ///< the virtual transducer (preset or file); on a card, its rate is the chain's
  bool quiet_sensor = false;         ///< virtual: without the plant's sensor noise
  bool virtual_loopback = true;      ///< virtual: the drive through the plant's converters alone as the loopback
  double safe_level = 0.5;           ///< alsa: the largest drive peak the transducer may be played
  double fade_seconds = 0.02;        ///< alsa: the program's fade before and after a measurement
  AlsaCliOptions alsa;               ///< alsa: the card
};

/// Adds --backend, --plant, --quiet-sensor, --safe-level and the sound-card options to `cmd`, stored in `o`.
void add_backend_options(CLI::App* cmd, BackendOptions& o);

/// A backend opened for playing: the simulated plant, or a started sound card (stopped when this ends).
class BackendPlayer {
 public:
  /// Opens the backend of `o`; the virtual transducer's noise seeds start at `seed`. Throws std::runtime_error when
  /// the card does not stream within 5 s, std::invalid_argument when it cannot be measured through.
  BackendPlayer(const BackendOptions& o, std::uint64_t seed);
  ~BackendPlayer();
  BackendPlayer(const BackendPlayer&) = delete;
  BackendPlayer& operator=(const BackendPlayer&) = delete;

  /// Plays a drive (within safe_level()) and returns what was recorded, aligned to it.
  usecases::PlayFunction play();
  /// The chain's (and the record's) rate, Hz: the plant's.
  double fs() const { return plant_.fs; }
  /// The largest drive peak a play may have: 1 on the virtual transducer, the card's safe level on a card.
  double safe_level() const;
  /// "virtual" or "alsa".
  const std::string& name() const { return options_.backend; }
  /// The plant simulated (on a card: the one whose rate the chain runs at).
  const models::PlantConfig& plant() const { return plant_; }
  /// The chain file `path` (the default chain when empty), refused naming both rates when it runs at another than fs().
  engine::ChainConfig chain(const std::string& path) const;

 private:
  BackendOptions options_;
  models::PlantConfig plant_;
  std::uint64_t seed_;
  std::unique_ptr<engine::Chain> chain_;
  std::unique_ptr<engine::AlsaBackend> card_;
};

}  // namespace panelbass::cli
