#pragma once
// Measures a virtual transducer the way the thesis measured its prototype: from simulated data only,
// never from the configuration. Used to check the presets and shown by `panelbass plant survey`.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "models/plant/plant_config.h"

namespace panelbass::models {

/// How a plant is surveyed.
struct PlantSurveySpec {
  std::size_t estimation_samples = 10000;  ///< uniform white noise, as in the thesis
  std::size_t validation_samples = 2000;
  double amplitude = 1.0;                  ///< drive of the noise excitation
  Eigen::Index fir_taps = 300;             ///< the linear model: FIR by least squares
  Eigen::Index max_lag = 1000;             ///< cross-correlation lags looked at
  std::size_t frf_samples = 65536;         ///< record for the frequency response
  std::size_t frf_segment = 2048;
  std::vector<double> distortion_frequencies{40.0, 80.0, 160.0, 320.0};
  double distortion_amplitude = 0.8;       ///< sine drive for the harmonic distortion
  std::uint64_t seed = 1;
};

/// Harmonic distortion at one frequency.
struct DistortionPoint {
  double frequency_hz = 0.0;
  double h2_db = 0.0;   ///< relative to the fundamental
  double h3_db = 0.0;
  double thd_pct = 0.0;
};

/// What the survey measured.
struct PlantSurvey {
  int delay_samples = 0;            ///< from the cross-correlation
  int impulse_length_samples = 0;   ///< where the cross-correlation sinks into its noise band
  double main_resonance_hz = 0.0;   ///< peak of |H| below 600 Hz
  double upper_resonance_hz = 0.0;  ///< peak of |H| from 600 Hz to 0.45·fs
  double notch_hz = 0.0;            ///< minimum of |H| between 600 Hz and the upper resonance
  double notch_depth_db = 0.0;      ///< notch level below the median level from 400 to 800 Hz
  double j_linear_est_pct = 0.0;    ///< simulation J of the FIR on its estimation data
  double j_linear_val_pct = 0.0;    ///< simulation J of the FIR on validation data
  double j_noise_pct = 0.0;         ///< J of the sensor noise alone (noisy vs noise-free output)
  std::vector<DistortionPoint> distortion;  ///< measured on the noise-free plant
};

/// Surveys `plant` (sensor noise seeded by spec.seed + 1).
PlantSurvey survey_plant(const PlantConfig& plant, const PlantSurveySpec& spec = {});

/// The survey as JSON.
nlohmann::json survey_to_json(const PlantSurvey& survey);

}  // namespace panelbass::models
