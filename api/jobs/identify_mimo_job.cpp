#include "api/jobs/identify_mimo_job.h"

#include <limits>
#include <optional>
#include <string>

#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/record_store.h"
#include "dsp/data_error.h"
#include "models/linear/mimo_model.h"
#include "usecases/identify_mimo.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The most input or output columns a request names.
constexpr std::size_t kMaxColumns = 64;

// The request of filled-in params, without its records.
usecases::IdentifyMimoRequest mimo_request(const json& params) {
  usecases::IdentifyMimoRequest q;
  q.inputs = params.at("inputs").get<std::vector<std::string>>();
  q.outputs = params.at("outputs").get<std::vector<std::string>>();
  q.order = params.at("order").get<int>();
  q.taps = params.at("taps").get<long>();
  q.ridge = params.at("ridge").get<double>();
  q.max_iterations = params.at("max_iterations").get<int>();
  q.val_realizations = params.at("val_realizations").get<long>();
  return q;
}

// A list of column names at `key`; `fallback` when absent.
void columns(ParamReader& r, const std::string& key, const std::vector<std::string>& fallback) {
  const json* v = r.member(key);
  if (v == nullptr || v->is_null()) {
    r.set(key, fallback);
    return;
  }
  if (!v->is_array() || v->size() > kMaxColumns) {
    refuse(r.path_of(key), "expected an array of at most " + std::to_string(kMaxColumns) + " column names, got " + shown(*v));
  }
  for (const json& c : *v) {
    if (!c.is_string()) refuse(r.path_of(key), "expected column names (strings), got " + shown(c));
  }
  r.set(key, *v);
}

// The uploaded record `id`, read as a periodic CSV by the request's columns; std::invalid_argument "<where>: …".
dsp::PeriodicRecord periodic_record(const JobEnvironment& env, const std::string& id, const usecases::IdentifyMimoRequest& q,
                                    const std::string& where) {
  const std::optional<StoredRecord> entry = env.records != nullptr ? env.records->find(id) : std::nullopt;
  if (!entry) refuse(where, "no uploaded record \"" + id + "\" (GET /api/records lists them)");
  if (entry->file != "csv") refuse(where, "record " + id + " is a " + entry->file + " file; a periodic record is a CSV");
  dsp::PeriodicColumns names;
  names.inputs = q.inputs;
  names.outputs = q.outputs;
  try {
    return dsp::read_periodic_csv(env.records->file(id), names, entry->fs);
  } catch (const dsp::DataError& e) {
    // The message names the stored file; the client knows it as its record id.
    std::string what = e.what();
    const std::string path = env.records->file(id).string();
    if (const std::size_t at = what.find(path); at != std::string::npos) what.replace(at, path.size(), "record " + id);
    refuse(where, what);
  }
}

json identify_mimo_params(const json& params, const JobEnvironment& env) {
  const usecases::IdentifyMimoRequest d;
  ParamReader r(params, "params");
  const std::optional<std::string> record = r.id("record", true);
  if (!is_record_id(*record)) refuse(r.path_of("record"), "expected an uploaded record \"r…\" (a periodic CSV), got \"" + *record + "\"");
  columns(r, "inputs", d.inputs);
  columns(r, "outputs", d.outputs);
  r.integer("order", d.order, -kAnyInteger, kAnyInteger);
  r.integer("taps", d.taps, -kAnyInteger, kAnyInteger);
  r.number("ridge", d.ridge, kAnyFinite);
  r.integer("max_iterations", d.max_iterations, -kAnyInteger, kAnyInteger);
  r.integer("val_realizations", d.val_realizations, -kAnyInteger, kAnyInteger);
  json filled = r.finish();
  filled["record"] = *record;
  usecases::IdentifyMimoRequest q = mimo_request(filled);
  q.records.push_back(periodic_record(env, *record, q, "params.record"));
  q.record_names.push_back(*record);
  q.fs = q.records.back().fs;
  check_request([&] { usecases::check(q); });
  return filled;
}

json identify_mimo_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  usecases::IdentifyMimoRequest q = mimo_request(params);
  const std::string id = params.at("record").get<std::string>();
  progress.at(0.0, "reading record " + id);
  q.records.push_back(periodic_record(env, id, q, "params.record"));
  q.record_names.push_back("uploaded record " + id);
  q.fs = q.records.back().fs;
  progress.span(0.05, 0.95);
  usecases::IdentifyMimoReport report;
  check_request([&] { report = usecases::identify_mimo(q, progress); });
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  // The model file itself: "mimo" is no kind of the model registry (models/kinds), so the store does not keep it.
  return {{"model", models::mimo_model_to_json(report.model)},
          {"j_est_pct", report.summary.at("J_est_pct")},
          {"j_val_pct", report.summary.at("J_val_pct")},
          {"summary", report.summary},
          {"warnings", report.warnings}};
}

}  // namespace

JobKind identify_mimo_job() { return {"identify-mimo", identify_mimo_params, identify_mimo_work}; }

}  // namespace panelbass::api
