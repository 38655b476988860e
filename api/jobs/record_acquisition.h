#pragma once
// Where the data of a job comes from: an excitation of its own, played through the backend (noise, a
// multisine, or the LQ controller's drive for a controller design's program), or the record of a finished
// excite job. The params side checks the choice before the job is queued; the work side acquires it.

#include <nlohmann/json.hpp>
#include <string>

#include "api/job_queue.h"
#include "api/jobs/excitation_record.h"
#include "api/jobs/job_environment.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "usecases/excite.h"

namespace panelbass::api {

/// Share of a job's progress given to an excitation of its own.
inline constexpr double kExcitationShare = 0.1;

/// The excite params at `path` (the excite kind's own params, or the "excite" field of another kind),
/// defaults filled in; refused when the backend cannot be excited (a sound card).
nlohmann::json excite_params(const nlohmann::json& params, const std::string& path, const JobEnvironment& env);

/// Reads where an identify/analyze/diagnose job's data comes from: "record" (a succeeded excite job "j…", or an
/// uploaded record "r…" with its "val_fraction") or "excite" (an excitation of its own, the default), filling
/// exactly one of them. Returns the validation samples the job will have, and in `validation_path` the field
/// to name when they are missing.
long long record_source(ParamReader& r, const JobEnvironment& env, std::string& validation_path);

/// The share of an uploaded record that validates unless a job says otherwise: the excite job's default split
/// (10000 estimation and 5000 validation samples).
inline constexpr double kDefaultValFraction = 1.0 / 3.0;

/// An uploaded record's two parts: the first `estimation` samples, then the last `validation`.
struct RecordSplit {
  long long estimation;  ///< samples that estimate
  long long validation;  ///< samples that validate (the record's end)
};

/// The parts of `samples` with `val_fraction` of them (rounded to the nearest sample) validating.
RecordSplit split_record(long long samples, double val_fraction);

/// True when the succeeded excite job `id` recorded harmonic weights (a control excitation).
bool record_has_weights(const JobEnvironment& env, const std::string& id);

/// The excitation use case's request of filled-in excite params at `env`'s rate and safe level; the feedforward of a
/// control excitation read from the store when `with_model`.
usecases::ExciteRequest excite_request(const nlohmann::json& excite, const JobEnvironment& env, bool with_model);

/// Plays a drive through `env`'s backend as an excitation reads it: on a sound card by the card measurement protocol
/// (env.measure), on the virtual transducer env.excite with the drive through its converters alone as the loopback.
usecases::PlayFunction excitation_play(const JobEnvironment& env);

/// Runs the excitation of filled-in excite params: estimation part (seed), then validation part (seed + 1).
ExcitationRecord run_excitation(const nlohmann::json& excite, const JobEnvironment& env, JobProgress& progress);

/// A job's data and where it came from ("job j3" or "excitation of j5").
struct SourcedRecord {
  ExcitationRecord record;  ///< the data
  std::string source;       ///< where it came from
};

/// Puts `data` into a use case's request of an estimation and a validation record (u_est, y_est, u_val, y_val,
/// fs: the engine's, data_name, val_name: "<source> (validation)" when it has that part).
template <typename Request>
void put_record(Request& q, const SourcedRecord& data, double fs) {
  q.u_est = data.record.u_est;
  q.y_est = data.record.y_est;
  q.u_val = data.record.u_val;
  q.y_val = data.record.y_val;
  q.fs = fs;
  q.data_name = data.source;
  q.val_name = q.u_val.size() > 0 ? data.source + " (validation)" : "";
}

/// The data of checked params (record_source), over the first kExcitationShare of the job's progress.
SourcedRecord acquire_record(const nlohmann::json& params, const JobEnvironment& env, JobProgress& progress,
                             const JobControl& control);

}  // namespace panelbass::api
