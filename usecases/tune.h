#pragma once
// Tune (issue #56): the whole pipeline that cancels a transducer's distortion, through whatever plays it —
// measure (a multisine; the drive, or its loopback, and the coil current recorded) → the gray-box model from the
// current (and the sensor when asked: models/control/mirror_current_fit.h) → the friction refined on quiet sines
// (models/control/mirror_friction_refit.h) → the mirror filter → verify at equal output level
// (usecases/verify.h, the verify verb's) → keep the filter only where it helps. Each step is reported with
// what it found; a step that fails ends the tune and says why.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/chain_file.h"
#include "usecases/design_mirror.h"
#include "usecases/equal_output_thd.h"
#include "usecases/progress.h"
#include "usecases/transducer_port.h"

namespace panelbass::usecases {

/// What a tune is asked.
struct TuneRequest {
  /// The chain as the engine runs it (its band-pass and limiter); the tune puts its filter in the feedforward
  /// slot and leaves the feedback slot empty. Its fs is the transducer's rate.
  engine::ChainConfig chain;
  double safe_level = 1.0;         ///< the largest drive peak the transducer may be played, (0, 1]
  long long samples = 30000;       ///< the measurement's multisine, samples (one period; ≥ 3000)
  double amplitude = 0.5;          ///< its peak, within (0, safe_level]
  double f_min = 10.0;             ///< its lowest line, Hz
  double f_max = 300.0;            ///< its highest line, Hz (below fs/2)
  std::uint64_t seed = 1;          ///< its phases
  /// What the sensor measures, for it to join the fit ("none": the current alone, as Klippel's controller)
  std::string sensor_kind = "none";
  int max_delay = 4;               ///< largest drive-to-voltage delay the fit searches, samples
  /// Refit the friction's velocity scale on the current's harmonics of two quiet sines below the resonance
  /// (models/control/mirror_friction_refit.h), played at verify's lowest level, and, when no sensor joins the fit and
  /// that level is at most models::kEddySearchLargestLevel, search [M1]'s eddy-current branch on the same sines
  bool refine_friction = true;
  EqualOutputSettings verify;      ///< the probes verify plays
  /// The filter is kept when verify credits it with at least this cut somewhere and nowhere less than −1 dB.
  double keep_min_cut_db = 3.0;
};

/// One step of a tune: what it did and found.
struct TuneStep {
  std::string name;        ///< "measure", "fit", "refine", "verify", "decide"
  double seconds = 0.0;    ///< wall time it took
  nlohmann::json summary;  ///< its figures
};

/// What a tune did.
struct TuneReport {
  std::vector<TuneStep> steps;                 ///< in order
  std::optional<DesignMirrorReport> mirror;    ///< the filter designed (its fit usable)
  std::optional<EqualOutputReport> verify;     ///< its verification
  bool keep = false;                           ///< the filter helps: it is to join the chain
  std::string decision;                        ///< why it was kept or left out, in words
  std::vector<std::string> warnings;           ///< what the steps warned of
  /// The other stages a chain can have, each with why the tune leaves it out.
  std::vector<std::string> left_out;
  Eigen::VectorXd drive;                       ///< the measurement's multisine as sent (step 1)
  Playback measurement;                        ///< what playing it recorded: the fit's record (step 1)
  /// {"steps":[{"name","seconds","summary"}],"keep","decision","verify":{…},"warnings","left_out"}.
  nlohmann::json to_json() const;
};

/// Throws RequestError naming the field for a request out of range.
void check(const TuneRequest& request);

/// The request's fields as the API names them (the tune job's params; the chain and safe level are the server's).
nlohmann::json to_json(const TuneRequest& request);

/// Runs the pipeline through `play`. Throws std::runtime_error naming the step that failed (a backend that
/// records no current, a fit that misses: then nothing is to be kept).
TuneReport tune(const TuneRequest& request, const PlayFunction& play, Progress& progress);

}  // namespace panelbass::usecases
