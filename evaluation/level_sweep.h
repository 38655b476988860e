#pragma once
// The distortion figure as a listener hears it (issue #34): THD, H2 and H3 against the *output*
// fundamental level, swept over program levels at each probe frequency, for a chain and for the plant
// driven alone at the drive that gives the same sensor fundamental level (found by an independent DFT of
// the sensor's output, not from the chain's own view), and two-tone intermodulation compared the same way.
// Klippel plots THD against level like this; the cut in dB at equal output level is what the chain buys.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "engine/chain_file.h"
#include "models/plant/plant_config.h"

namespace panelbass::evaluation {

/// What the level sweep measures.
struct LevelSweepOptions {
  std::vector<double> frequencies_hz{40.0, 80.0, 160.0, 320.0};  ///< probe sine frequencies
  std::vector<double> program_amplitudes{0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5};  ///< program sine amplitudes
  int harmonics = 5;              ///< harmonics analysed (2..harmonics below fs/2)
  std::uint64_t seed = 1;         ///< the plant's sensor noise
  double settle_seconds = 0.5;    ///< run before the analysis window
  double analysis_seconds = 2.0;  ///< analysed (a whole number of periods of every probe: 0.5 Hz resolution)
  double imd_low_hz = 40.0;       ///< two-tone: the low (excursion) tone
  double imd_high_hz = 310.0;     ///< two-tone: the high tone (no harmonic of the low one)
  double imd_ratio = 4.0;         ///< amplitude of the low tone over the high one (SMPTE's 4:1)
};

/// Harmonic figures of one sensor record at one probe (the DFT at each harmonic's frequency).
struct HarmonicFigures {
  double fundamental = 0.0;  ///< amplitude of the fundamental at the sensor, V
  double thd_pct = 0.0;      ///< total harmonic distortion, percent
  double h2_db = 0.0;        ///< H2 relative to the fundamental, dB
  double h3_db = 0.0;        ///< H3 relative to the fundamental, dB
  double drive_peak = 0.0;   ///< largest |drive| over the analysed window
};

/// One program level at one probe: the chain, and the plant alone at the same output level.
struct LevelPoint {
  double program_amplitude = 0.0;  ///< the program sine's amplitude into the chain
  HarmonicFigures chain;           ///< the chain's figures
  double plant_drive = 0.0;        ///< the plant-alone sine amplitude whose output fundamental equals the chain's
  HarmonicFigures plant;           ///< the plant alone at that drive
  double cut_db = 0.0;             ///< 20·log10(plant THD / chain THD): > 0 when the chain cuts distortion
  double noise_floor_pct = 0.0;    ///< the THD the sensor noise alone shows at this fundamental
  bool reachable = false;          ///< the chain's limiter left the drive unchanged and the plant reached the level
  bool needs_more_drive = false;   ///< the chain asked for full scale or more at some sample (more than it can give)
  double peak_demand = 0.0;        ///< the largest |drive| the chain asked for before its limiter
};

/// The sweep at one probe frequency.
struct LevelCurve {
  double frequency_hz = 0.0;       ///< the probe frequency
  std::vector<LevelPoint> points;  ///< one per program amplitude, in the options' order
};

/// Two-tone intermodulation at one level: sidebands f_high ± f_low and f_high ± 2·f_low over the high tone.
struct ImdPoint {
  double program_amplitude = 0.0;  ///< the low tone's amplitude in the program (the high tone's is 1/ratio of it)
  double output_low = 0.0;         ///< the low tone's amplitude at the sensor (equal for both), V
  double chain_imd_pct = 0.0;      ///< the chain's intermodulation distortion, percent
  double plant_scale = 0.0;        ///< the factor on the two-tone that drives the plant alone to the same low tone
  double plant_imd_pct = 0.0;      ///< the plant alone's, percent
  double cut_db = 0.0;             ///< 20·log10(plant / chain)
  bool reachable = false;          ///< as LevelPoint::reachable
};

/// The whole sweep.
struct LevelSweep {
  std::vector<LevelCurve> curves;  ///< one per probe frequency
  std::vector<ImdPoint> imd;       ///< one per program amplitude
  /// The smallest cut over the reachable points at `frequency_hz` where the chain's THD is more than 3 dB
  /// above the noise floor (a point at the floor counts as reaching it); NaN when no point is reachable.
  double worst_cut_db(double frequency_hz) const;
};

/// Runs the sweep of `config` on `plant` (the plant's sensor noise as configured). Each chain point is
/// rendered through the engine's own chain; the plant-alone drive is found by iterating its amplitude until
/// the sensor fundamental matches the chain's to 0.01 dB. `progress(done, total)` is called as points finish.
/// Throws std::invalid_argument naming a bad option or a plant at another rate than the chain.
LevelSweep sweep_levels(const engine::ChainConfig& config, const models::PlantConfig& plant,
                        const LevelSweepOptions& options = {},
                        const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace panelbass::evaluation
