#include "api/jobs/record_acquisition.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "api/jobs/stored_models.h"
#include "api/model_store.h"
#include "models/plant/converter_loop.h"
#include "models/control/feedback_design.h"
#include "usecases/excite.h"

namespace panelbass::api {

using nlohmann::json;

usecases::PlayFunction excitation_play(const JobEnvironment& env) {
  return [&env](const Eigen::VectorXd& drive) {
    if (env.measure) return env.measure(drive);
    if (!env.excite) throw std::runtime_error("no backend to excite");
    usecases::Playback p;
    p.sensor = env.excite(drive);
    if (env.plant) p.loopback = models::converters_alone(*env.plant, drive);
    return p;
  };
}

usecases::ExciteRequest excite_request(const json& excite, const JobEnvironment& env, bool with_model) {
  usecases::ExciteRequest q;
  q.signal = excite.at("signal").get<std::string>();
  q.samples = excite.at("samples").get<long long>();
  q.validation_samples = excite.at("validation_samples").get<long long>();
  q.amplitude = excite.at("amplitude").get<double>();
  q.seed = excite.at("seed").get<std::uint64_t>();
  q.fs = env.fs;
  q.safe_level = env.safe_level;
  if (q.signal == "control") {
    q.feedforward_name = excite.at("feedforward_model").get<std::string>();
    if (with_model) q.feedforward_model = stored_model_file(env, q.feedforward_name);
    q.sine_peak = excite.at("sine_peak").get<double>();
    q.program_share = excite.at("program_share").get<double>();
  }
  return q;
}

// The excite params at `path` (the excite kind's own params, or the "excite" field of another kind); refused
// when the backend cannot be excited (a sound card).
json excite_params(const json& params, const std::string& path, const JobEnvironment& env) {
  if (!env.excite && !env.measure) {
    refuse(path, "this server has no backend to excite: identify from a recording of the transducer (POST "
                 "/api/records) instead");
  }
  const usecases::ExciteRequest defaults;
  ParamReader r(params, path);
  const std::string signal = r.choice("signal", defaults.signal, {"noise", "multisine", "control"});
  r.integer("samples", defaults.samples, kMinSamples, kMaxSamples);
  r.integer("validation_samples", defaults.validation_samples, 0, kMaxSamples);
  r.number("amplitude", std::min(defaults.amplitude, env.safe_level), {0.0, 1.0, true, false});
  r.integer("seed", static_cast<long long>(defaults.seed), 0, kMaxSeed);
  if (signal == "control") {
    require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
    r.number("sine_peak", defaults.sine_peak, {0.0, 1.0, true, false});
    r.number("program_share", defaults.program_share, {0.0, 1.0, false, false});
  }
  json filled = r.finish();
  try {
    usecases::check(excite_request(filled, env, false));
  } catch (const usecases::RequestError& e) {
    refuse(path + "." + e.field(), e.problem());
  }
  return filled;
}

// Where the data of an identify/analyze/diagnose job comes from: "record" (a succeeded excite job "j…" or an
// uploaded record "r…") or "excite" (an excitation of its own, the default). Fills exactly one of them (and,
// for an uploaded record, its "val_fraction"); returns the validation samples the job will have, and in
// `validation_path` the field to name when they are missing.
long long record_source(ParamReader& r, const JobEnvironment& env, std::string& validation_path) {
  const json* record = r.member("record");
  const json* excite = r.member("excite");
  const json* fraction = r.member("val_fraction");
  if (record != nullptr && excite != nullptr) {
    refuse(r.path_of("record"), "give either \"record\" or \"excite\", not both");
  }
  const bool uploaded = record != nullptr && record->is_string() && is_record_id(record->get<std::string>());
  if (fraction != nullptr && !uploaded) {
    refuse(r.path_of("val_fraction"), "splits an uploaded record (\"record\":\"r…\"); an excite job's record and an "
                                      "excitation have their own validation part (excite.validation_samples)");
  }
  if (uploaded) {
    const std::string where = r.path_of("record");
    const std::string id = record->get<std::string>();
    const std::optional<StoredRecord> entry = env.records != nullptr ? env.records->find(id) : std::nullopt;
    if (!entry) refuse(where, "no uploaded record \"" + id + "\" (GET /api/records lists them)");
    const RecordSplit split = split_record(static_cast<long long>(entry->samples),
                                           r.number("val_fraction", kDefaultValFraction, {0.0, 0.9, false, false}));
    if (split.estimation < kMinSamples || (split.validation > 0 && split.validation < kMinSamples)) {
      refuse(r.path_of("val_fraction"),
             "splits record " + id + "'s " + std::to_string(entry->samples) + " samples into " +
                 std::to_string(split.estimation) + " for estimation and " + std::to_string(split.validation) +
                 " for validation; each part needs at least " + std::to_string(kMinSamples) + " (or validation 0)");
    }
    r.set("record", id);
    validation_path = r.path_of("val_fraction");
    return split.validation;
  }
  if (record != nullptr) {
    const std::string where = r.path_of("record");
    if (!record->is_string()) refuse(where, "expected the id of a finished excite job or an uploaded record, got " + shown(*record));
    const std::string id = record->get<std::string>();
    if (!is_valid_id(id)) refuse(where, "not a job id: " + shown(*record));
    const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
    if (!result) {
      refuse(where, "no succeeded job \"" + id + "\" (the record must name a finished excite job \"j…\" or an uploaded "
                    "record \"r…\")");
    }
    const ExcitationRecord data = excitation_record_from_result(*result, env.fs, where + ": job " + id, env.records);
    r.set("record", id);
    validation_path = where;
    return data.u_val.size();
  }
  const json filled = excite_params(excite != nullptr ? *excite : json::object(), r.path_of("excite"), env);
  r.set("excite", filled);
  validation_path = r.path_of("excite") + ".validation_samples";
  return filled.at("validation_samples").get<long long>();
}

RecordSplit split_record(long long samples, double val_fraction) {
  const auto validation = static_cast<long long>(std::llround(static_cast<double>(samples) * val_fraction));
  return {samples - validation, validation};
}

bool record_has_weights(const JobEnvironment& env, const std::string& id) {
  const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
  if (!result) return false;
  if (result->contains("record")) return result->at("record").contains("w_est");  // kept inline
  const json columns = result->value("record_columns", json::array());
  return std::find(columns.begin(), columns.end(), json("w")) != columns.end();
}

ExcitationRecord run_excitation(const json& excite, const JobEnvironment& env, JobProgress& progress) {
  return usecases::excite(excite_request(excite, env, true), excitation_play(env), progress).record;
}

SourcedRecord acquire_record(const json& params, const JobEnvironment& env, JobProgress& progress,
                             const JobControl& control) {
  progress.span(0.0, kExcitationShare);
  if (params.contains("record") && params.at("record").is_string() && is_record_id(params.at("record").get<std::string>())) {
    const std::string id = params.at("record").get<std::string>();
    if (env.records == nullptr || !env.records->find(id)) {
      throw std::runtime_error("params.record: uploaded record " + id + " is no longer stored");
    }
    const dsp::Record data = env.records->data(id);
    const RecordSplit split = split_record(static_cast<long long>(data.samples()), params.at("val_fraction").get<double>());
    // The first part estimates, the rest (the record's end) validates, as an excite job's two parts.
    ExcitationRecord out;
    const auto part = [&](const char* column, Eigen::VectorXd& est, Eigen::VectorXd& val) {
      const Eigen::VectorXd& x = data.column(column);
      est = x.head(split.estimation);
      val = x.tail(split.validation);
    };
    part("u", out.u_est, out.u_val);
    part("y", out.y_est, out.y_val);
    if (data.columns.size() > 2) part("i", out.i_est, out.i_val);
    progress.at(1.0, "uploaded record " + id);
    return {out, "uploaded record " + id};
  }
  if (params.contains("record") && params.at("record").is_string()) {
    const std::string id = params.at("record").get<std::string>();
    const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
    if (!result) throw std::runtime_error("params.record: job " + id + " is no longer available");
    progress.at(1.0, "record of " + id);
    return {excitation_record_from_result(*result, env.fs, "params.record: job " + id, env.records), "job " + id};
  }
  return {run_excitation(params.at("excite"), env, progress), "excitation of " + control.job_id()};
}

}  // namespace panelbass::api
