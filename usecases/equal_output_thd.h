#pragma once
// Verify at equal output level, through a backend (issue #56): at each probe frequency and program level the
// chain's drive (the engine's own chain, run offline on the program) is played through the transducer, then the
// transducer alone is driven by a sine whose amplitude is searched until its sensor fundamental equals the
// chain's; the THD cut is what the chain buys at the output level a listener hears. All probes of one pass play
// as one stepped recording (a fade, a settling time and an analysis window of whole periods each), so a sound
// card's calibration is paid once per pass. Offline, evaluation/level_sweep.h does the same on a plant file.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dsp/harmonics.h"
#include "engine/chain_file.h"
#include "usecases/progress.h"
#include "usecases/transducer_port.h"

namespace panelbass::usecases {

/// Where and how long the probes play.
struct EqualOutputSettings {
  std::vector<double> frequencies{40.0, 80.0, 160.0};  ///< probe sines, each within (0, fs/4]
  std::vector<double> levels{0.1, 0.2, 0.3};              ///< the chain's program sine amplitudes, each in (0, 1]
  double settle_seconds = 0.3;    ///< played before each analysis window (≥ 0.1 s; a 50 ms fade in first)
  double analysis_seconds = 0.7;  ///< analysed, rounded to whole periods of the probe (≥ 0.2 s)
  int max_plays = 4;              ///< passes of the transducer alone searching its drive (1..8)
};

/// What is verified: a chain as the engine runs it, played through a transducer whose drive may not exceed a level.
struct EqualOutputRequest {
  engine::ChainConfig chain;        ///< the chain (its models in their slots), at the transducer's rate
  double safe_level = 1.0;          ///< the largest drive peak the transducer may be played, (0, 1]
  EqualOutputSettings settings;     ///< probes and their timing
};

/// One THD as read from a noisy sensor.
struct ThdReading {
  double thd_pct = 0.0;         ///< with the noise's expected share taken out (dsp::steady_thd)
  double floor_pct = 0.0;       ///< what the noise alone reads
  double uncertainty_db = 0.0;  ///< one standard deviation of thd_pct from that noise
  bool noise_bound = false;     ///< within 3 dB of the floor, or moved by more than 1 dB by the noise
  double at_most_pct = 0.0;     ///< with noise_bound: what the THD is at most
};

/// One probe at one program level.
struct EqualOutputPoint {
  double frequency_hz = 0.0;
  double program_level = 0.0;       ///< the chain's program sine amplitude
  bool reachable = false;           ///< the chain's limiter untouched, its drive within the safe level, the plant matched
  std::string unreachable_because;  ///< in words, when not reachable
  double chain_drive_peak = 0.0;    ///< the chain's largest |drive| over the point
  double output_level = 0.0;        ///< the sensor fundamental through the chain
  double plant_drive = 0.0;         ///< the sine amplitude that drives the transducer alone to that output
  double plant_output_level = 0.0;  ///< the sensor fundamental it gave (within 0.1 dB of output_level when matched)
  ThdReading chain, plant;          ///< through the chain; the transducer alone at equal output
  std::optional<double> cut_db;           ///< 20·log10(plant / chain THD), both read above their noise
  std::optional<double> cut_at_least_db;  ///< the chain's THD noise-bound: the cut is at least this
};

/// The verification.
struct EqualOutputReport {
  std::vector<EqualOutputPoint> points;  ///< frequency-major, in the settings' order
  int plays = 0;                         ///< recordings made
  std::vector<std::string> warnings;     ///< a level the chain makes worse, a plant drive not matched, in words
  /// The cut a point is credited with: cut_db, else cut_at_least_db; nullopt when neither is known.
  static std::optional<double> credited_cut(const EqualOutputPoint& point);
  /// The smallest credited cut over the reachable points at `frequency_hz` (nullopt when none has one).
  std::optional<double> worst_cut_db(double frequency_hz) const;
  /// {"points":[…],"plays","warnings","worst_cut_db":{"<Hz>":…}}; unknown numbers as null.
  nlohmann::json to_json() const;
  /// "thd_vs_level_<Hz>": {"level","chain_thd_pct","plant_thd_pct"} per probe (the web draws these).
  nlohmann::json plots() const;
};

/// The settings' fields as the API names them (the verify job's params, the tune job's probes).
nlohmann::json to_json(const EqualOutputSettings& settings);

/// Throws RequestError naming the field ("frequencies", "levels", …) for settings out of range at `fs`.
void check(const EqualOutputSettings& settings, double fs);

/// Plays the probes through `play` (the chain's drive, then the transducer alone) and compares them at equal
/// output. Throws std::runtime_error when a recording has no usable fundamental.
EqualOutputReport verify_equal_output(const EqualOutputRequest& request, const PlayFunction& play, Progress& progress);

}  // namespace panelbass::usecases
