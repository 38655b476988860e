#include "api/jobs/record_acquisition.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "api/jobs/lq_band_pass.h"
#include "api/jobs/stored_models.h"
#include "api/model_store.h"
#include "dsp/excitation.h"
#include "models/plant/converter_loop.h"
#include "models/control/feedback_design.h"
#include "models/control/lq_feedforward.h"
#include "models/control/model_probes.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The drive of `samples`: uniform white noise in [−amplitude, amplitude] or a random-phase multisine
// over the whole band with that peak; clamped to [−1, 1] (the safety rule).
Eigen::VectorXd excitation_signal(const std::string& signal, Eigen::Index samples, double amplitude, std::uint64_t seed,
                                  double fs) {
  Eigen::VectorXd drive;
  if (signal == "multisine") {
    dsp::MultisineSpec spec;
    spec.period = static_cast<std::size_t>(std::min<Eigen::Index>(4096, samples));
    spec.periods = static_cast<std::size_t>((samples + spec.period - 1) / spec.period);
    spec.fs = fs;
    spec.f_min = 0.0;
    spec.f_max = fs / 2.0;
    spec.amplitude = amplitude;
    spec.seed = seed;
    drive = dsp::multisine(spec).signal.head(samples);
  } else {
    drive = dsp::uniform_noise(static_cast<std::size_t>(samples), amplitude, seed);
  }
  if (!drive.allFinite()) throw std::runtime_error("the excitation has a non-finite sample");
  return drive.cwiseMax(-1.0).cwiseMin(1.0);
}

// Plays `drive` through the backend; the response must be as long and finite. On a sound card, the part's
// calibration report goes to `record.card`, the current, when captured, to `current` and the loopback, when
// captured, to `loopback`; on the virtual transducer `loopback` is the drive through its converters alone.
Eigen::VectorXd play(const JobEnvironment& env, const Eigen::VectorXd& drive, ExcitationRecord& record,
                     Eigen::VectorXd& current, Eigen::VectorXd& loopback) {
  if (!env.excite && !env.measure) throw std::runtime_error("no backend to excite");
  Eigen::VectorXd response;
  if (env.measure) {
    MeasuredResponse measured = env.measure(drive);
    if (measured.y.size() == 0) throw std::runtime_error("the card captures no sensor, and this job reads one (panelbass serve --sensor-channel)");
    response = std::move(measured.y);
    current = std::move(measured.i);
    loopback = std::move(measured.loopback);
    if (record.card.is_null()) record.card = nlohmann::json::array();
    record.card.push_back(std::move(measured.report));
  } else {
    response = env.excite(drive);
    if (env.plant) loopback = models::converters_alone(*env.plant, drive);
  }
  if (response.size() != drive.size()) {
    throw std::runtime_error("the backend recorded " + std::to_string(response.size()) + " samples for a drive of " +
                             std::to_string(drive.size()));
  }
  if (!response.allFinite()) throw std::runtime_error("the backend recorded a non-finite response");
  return response;
}

}  // namespace

// The excite params at `path` (the excite kind's own params, or the "excite" field of another kind); refused
// when the backend cannot be excited (a sound card).
json excite_params(const json& params, const std::string& path, const JobEnvironment& env) {
  if (!env.excite && !env.measure) {
    refuse(path, "this server has no backend to excite: identify from a recording of the transducer (POST "
                 "/api/records) instead");
  }
  ParamReader r(params, path);
  const std::string signal = r.choice("signal", "noise", {"noise", "multisine", "control"});
  const long long samples = r.integer("samples", 10000, kMinSamples, kMaxSamples);
  const long long validation = r.integer("validation_samples", 5000, 0, kMaxSamples);
  if (validation > 0 && validation < kMinSamples) {
    refuse(r.path_of("validation_samples"), "must be 0 (none) or at least " + std::to_string(kMinSamples) + ", got " +
                                                std::to_string(validation));
  }
  const double amplitude = r.number("amplitude", std::min(0.3, env.safe_level), {0.0, 1.0, true, false});
  if (signal != "control" && amplitude > env.safe_level) {
    refuse(r.path_of("amplitude"), "exceeds the sound card's safe level " + std::to_string(env.safe_level) +
                                       " (panelbass serve --safe-level), got " + std::to_string(amplitude));
  }
  r.integer("seed", 1, 0, kMaxSeed);
  // The plant in its operating regime (panelbass simulate --signal control): the LQ feedforward's output
  // for the controller design's program, noise then stepped sines, with per-sample harmonic weights.
  if (signal == "control") {
    if (samples < models::kMinControlSamples) {
      refuse(r.path_of("samples"), "a control excitation needs at least " + std::to_string(models::kMinControlSamples) +
                                       " samples, got " + std::to_string(samples));
    }
    if (validation > 0 && validation < models::kMinControlSamples) {
      refuse(r.path_of("validation_samples"), "must be 0 (none) or at least " + std::to_string(models::kMinControlSamples) +
                                                  " for a control excitation, got " + std::to_string(validation));
    }
    require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
    const models::FeedbackDesignOptions design;
    r.number("sine_peak", design.sine_peak, {0.0, 1.0, true, false});
    r.number("program_share", design.program_share, {0.0, 1.0, false, false});
  }
  return r.finish();
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
  const std::string signal = excite.at("signal").get<std::string>();
  const Eigen::Index samples = excite.at("samples").get<Eigen::Index>();
  const Eigen::Index validation = excite.at("validation_samples").get<Eigen::Index>();
  const double amplitude = excite.at("amplitude").get<double>();
  const std::uint64_t seed = excite.at("seed").get<std::uint64_t>();
  const double total = static_cast<double>(samples + validation);
  ExcitationRecord record;
  progress.at(0.0, "excitation: " + std::to_string(samples) + " samples of " + signal);
  if (signal == "control") {
    const models::LqFeedforward ff =
        models::lq_feedforward_from_json(stored_model_file(env, excite.at("feedforward_model").get<std::string>()));
    const std::vector<dsp::Biquad> band_pass = lq_band_pass(ff).filter;
    models::FeedbackDesignOptions design;
    design.sine_peak = excite.at("sine_peak").get<double>();
    design.program_share = excite.at("program_share").get<double>();
    // One part: the chain's drive for the design's program, played, and its steps' harmonic weights.
    const auto control_part = [&](Eigen::Index n, std::uint64_t part_seed, Eigen::VectorXd& u, Eigen::VectorXd& y,
                                  Eigen::VectorXd& w, Eigen::VectorXd& loopback) {
      design.samples = n;
      const models::ControlRecord part = models::control_record(ff, band_pass, design, part_seed);
      if (!part.u.allFinite()) throw std::runtime_error("the control excitation has a non-finite sample");
      // The safety rule, and on a card its safe level: the controller's drive is clipped to it.
      const double cap = std::min(1.0, env.safe_level);
      u = part.u.cwiseMax(-cap).cwiseMin(cap);
      Eigen::VectorXd current;
      y = play(env, u, record, current, loopback);
      w = models::harmonic_weights(part, y, env.fs);
    };
    control_part(samples, seed, record.u_est, record.y_est, record.w_est, record.l_est);
    if (validation > 0) {
      progress.at(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
      control_part(validation, seed + 1, record.u_val, record.y_val, record.w_val, record.l_val);
    }
    progress.at(1.0, "excitation recorded");
    return record;
  }
  record.u_est = excitation_signal(signal, samples, amplitude, seed, env.fs);
  record.y_est = play(env, record.u_est, record, record.i_est, record.l_est);
  if (validation > 0) {
    progress.at(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
    record.u_val = excitation_signal(signal, validation, amplitude, seed + 1, env.fs);
    record.y_val = play(env, record.u_val, record, record.i_val, record.l_val);
  }
  progress.at(1.0, "excitation recorded");
  return record;
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
