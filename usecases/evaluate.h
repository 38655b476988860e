#pragma once
// `evaluate` / the evaluate job: a controller chain run on a simulated transducer ([2C]): the response ripple, J_c
// and each probe sine's THD of the plant alone, band-pass + feedforward and the whole chain; optionally which
// nonlinear term makes the distortion, and THD against the output level beside the plant alone (a chain whose
// feedforward is a mirror filter has no J_c reference: the level sweep judges it).

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/chain_file.h"
#include "evaluation/chain_evaluation.h"
#include "evaluation/distortion_attribution.h"
#include "evaluation/level_sweep.h"
#include "models/plant/plant_config.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `evaluate` is asked.
struct EvaluateRequest {
  engine::ChainConfig chain;  ///< the chain evaluated (its models inline)
  std::string chain_name;     ///< where it came from (a file, the stored models)
  std::string plant = "panel-exciter";  ///< a preset, or the name of plant_config
  std::optional<models::PlantConfig> plant_config;  ///< the plant itself (none: the preset `plant`)
  std::vector<double> probes_hz = evaluation::EvaluationOptions{}.probe_hz;  ///< probe sines, 1..16 in (0, fs/2), Hz
  double probe_peak = evaluation::EvaluationOptions{}.probe_peak;  ///< steady band-pass + feedforward peak (0: knee), [0, 1]
  long noise_samples = evaluation::EvaluationOptions{}.noise_samples;  ///< white-noise record, 4096..100000000
  std::uint64_t seed = evaluation::EvaluationOptions{}.seed;  ///< noise program and sensor noise
  bool attribute = false;    ///< also each nonlinear term alone (which physics makes each probe's distortion)
  bool level_sweep = false;  ///< also THD against the output level (always for a mirror-filter chain)
  std::vector<double> levels = evaluation::LevelSweepOptions{}.program_amplitudes;  ///< the sweep's program amplitudes, (0, 1]
};

/// What `evaluate` found.
struct EvaluateReport {
  std::optional<evaluation::ChainEvaluation> evaluation;  ///< the table (none for a mirror-filter chain)
  std::optional<evaluation::LevelSweep> sweep;            ///< with level_sweep, or a mirror-filter chain
  std::vector<evaluation::TermDistortion> attribution;    ///< with attribute (and a table)
  /// {"plant","chain","noise_amplitude","jc_noise_floor_pct","probe_peak","probes_hz","ripple_band_hz","rows"}, and
  /// "level_sweep" and "attribution" when run.
  nlohmann::json summary;
};

/// Throws RequestError naming the field for a request out of range.
void check(const EvaluateRequest& request);

/// The request's fields (the chain and plant by their names), as the API echoes its params.
nlohmann::json to_json(const EvaluateRequest& request);

/// Evaluates the chain.
EvaluateReport evaluate(const EvaluateRequest& request, Progress& progress);

}  // namespace panelbass::usecases
