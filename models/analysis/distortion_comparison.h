#pragma once
// Harmonic distortion measured by stepped sine on the plant and on a model, side by side: the thesis's
// frequency-domain validation (figs 6.5–6.7: the fundamental and its harmonics against frequency, the
// process measured with tracking band-pass filters, the model by the DFT at each harmonic).

#include <Eigen/Core>
#include <complex>
#include <cstdint>
#include <functional>
#include <vector>

#include "models/kinds/model_file.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// Whether the plant's sensor noise is simulated during the measurement.
enum class SensorNoise {
  keep,  ///< as configured: what a measurement would see (a noise floor under the harmonics)
  off,   ///< noise-free: the distortion of the physics alone
};

/// The stepped-sine measurement: every amplitude is swept over every frequency.
struct DistortionSpec {
  std::vector<double> frequencies;   ///< requested fundamentals, Hz (snapped to whole periods, see stepped_sine)
  std::vector<double> amplitudes;    ///< drive amplitudes (raw drive units)
  std::size_t settle = 600;          ///< samples at each step before the measured part
  std::size_t measure = 3000;        ///< samples measured at each step
  int max_order = 5;                 ///< highest harmonic measured (H2..H{max_order})
  SensorNoise sensor_noise = SensorNoise::keep;  ///< for a plant only
  std::uint64_t noise_seed = 1;      ///< seeds the plant's sensor noise
};

/// The response at one frequency and amplitude.
struct DistortionRow {
  double frequency = 0.0;        ///< fundamental after snapping, Hz
  double amplitude = 0.0;        ///< drive amplitude
  double fundamental = 0.0;      ///< output amplitude at the fundamental (raw output units)
  /// Level of harmonic h = 2..max_order in dB re the fundamental, at index h − 2; NaN at or above fs/2.
  std::vector<double> harmonic_db;
  /// Harmonic h = 2..max_order relative to the fundamental as a complex ratio (dsp::HarmonicLevels::relative:
  /// level and phase against a cosine fundamental of phase zero), at index h − 2; NaN at or above fs/2.
  std::vector<std::complex<double>> harmonic_relative;
  double thd_percent = 0.0;      ///< 100·√(Σ_{h≥2} a_h²)/a_1 over the harmonics below fs/2 (NaN if none is)
};

/// Plant and model rows in the same order (amplitude-major, then frequency).
struct DistortionComparison {
  std::vector<DistortionRow> plant;
  std::vector<DistortionRow> model;
};

/// A system under test: drive in, output out (same length).
using SystemResponse = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

/// Stepped-sine distortion of any `system` at sample rate `fs`, one stepped sine per amplitude.
/// Throws std::invalid_argument for empty frequency or amplitude lists, max_order < 2, or a system
/// that returns an output of the wrong length or with a non-finite sample.
std::vector<DistortionRow> measure_distortion(const SystemResponse& system, double fs, const DistortionSpec& spec);

/// The distortion of the virtual transducer `plant` (models::simulate from rest, at the plant's fs).
std::vector<DistortionRow> plant_distortion(const PlantConfig& plant, const DistortionSpec& spec);

/// The distortion of `model` (AnyModel::simulate from rest, at the model's fs).
std::vector<DistortionRow> model_distortion(const AnyModel& model, const DistortionSpec& spec);

/// Both, side by side. Throws std::invalid_argument when the plant's and the model's fs differ.
DistortionComparison compare_distortion(const PlantConfig& plant, const AnyModel& model, const DistortionSpec& spec);

/// How much of `recorded`'s distortion a canceller that removes `model`'s harmonics would take away, dB:
/// 10·log10(Σ_h |R_h|² / Σ_h |R_h − M_h|²) over the harmonics measured in both (R, M relative to their own
/// fundamentals, DistortionRow::harmonic_relative). A correction of the drive acts on plant and model alike to
/// first order, so the plant keeps R − M: +inf when the model's harmonics are the recording's, 0 for a model
/// without harmonics, negative when the correction would add distortion (a harmonic of the right level and the
/// wrong phase). Throws std::invalid_argument when the rows are at different frequencies or share no harmonic.
double cancellable_db(const DistortionRow& recorded, const DistortionRow& model);

/// The same from the levels alone, with ||R_h| − |M_h|| for |R_h − M_h|: an upper bound of cancellable_db that
/// a model with every harmonic at the right level and the wrong phase would still reach.
double cancellable_magnitude_db(const DistortionRow& recorded, const DistortionRow& model);

}  // namespace panelbass::models
