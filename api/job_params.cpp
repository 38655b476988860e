#include "api/job_params.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "api/model_store.h"
#include "engine/chain_evaluation.h"
#include "models/control/feedback_design.h"
#include "models/control/model_probes.h"
#include "models/plant/plant_presets.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// Seeds are integers a JSON client can hold exactly (2^53).
constexpr long long kMaxSeed = 9'007'199'254'740'992LL;
// Highest model order, numerator length or network lag a job accepts; FIR taps may go further.
constexpr long long kMaxOrder = 40;
constexpr long long kMaxFirTaps = 2000;
// Iterations of any training loop.
constexpr long long kMaxIterations = 10'000;
// The NN feedback controller's input lags and rail penalty, as far as `panelbass design nn` takes them.
constexpr long long kMaxControllerLag = 100;
constexpr double kMaxRailPenalty = 1e12;
// Trainings from fresh initial weights in one design-nn job (each costs as much as the whole training).
constexpr long long kMaxRestarts = 20;
// Playbacks of each drive into the device a design-nn job tunes on (each costs a simulation of the record).
constexpr long long kMaxPlaybacks = 64;

// A short rendering of a value for a message: `"x"`, `12.5`, `[1,2]` (long ones cut).
std::string shown(const json& value) {
  std::string text = value.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw std::invalid_argument(path + ": " + what); }

// For a `where` that already names its subject ("params.record: job j3"): "<where> <what>".
[[noreturn]] void fail_after(const std::string& where, const std::string& what) { throw std::invalid_argument(where + " " + what); }

// `value` as an integer (an integral float such as 1e4 counts), or nullopt.
std::optional<long long> integral(const json& value) {
  if (value.is_number_integer()) {
    constexpr auto kLargest = static_cast<unsigned long long>(std::numeric_limits<long long>::max());
    if (value.is_number_unsigned() && value.get<unsigned long long>() > kLargest) return std::nullopt;
    return value.get<long long>();
  }
  if (value.is_number_float()) {
    const double d = value.get<double>();
    if (std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9.0e15) return static_cast<long long>(d);
  }
  return std::nullopt;
}

std::string list_text(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t k = 0; k < names.size(); ++k) text += (k ? ", " : "") + ("\"" + names[k] + "\"");
  return text;
}

// ----- the parts several kinds share -------------------------------------------------------------

// A stored model named by `key`, of one of `kinds`, at the engine's rate.
void stored_model(ParamReader& r, const std::string& key, bool required, const std::vector<std::string>& kinds,
                  const JobEnvironment& env) {
  const std::optional<std::string> id = r.id(key, required);
  if (!id) return;
  const std::string where = r.path_of(key);
  if (env.store == nullptr) fail(where, "no model store to read \"" + *id + "\" from");
  const std::optional<StoredModel> stored = env.store->find(*id);
  if (!stored) fail(where, "no stored model \"" + *id + "\"");
  if (std::find(kinds.begin(), kinds.end(), stored->kind) == kinds.end()) {
    std::string expected;
    for (std::size_t k = 0; k < kinds.size(); ++k) expected += (k ? " or " : "") + kinds[k];
    fail(where, "model " + *id + " is of kind \"" + stored->kind + "\", expected " + expected);
  }
  if (std::abs(stored->fs - env.fs) > 1e-9 * env.fs) {
    fail(where, "model " + *id + " runs at " + number_text(stored->fs) + " Hz, the engine at " + number_text(env.fs) + " Hz");
  }
}

// The excite params at `path` (the excite kind's own params, or the "excite" field of another kind); refused
// when the backend cannot be excited (a sound card).
json excite_params(const json& params, const std::string& path, const JobEnvironment& env) {
  if (!env.excite) {
    fail(path, "this server plays on a sound card (ALSA), which jobs cannot measure through yet: identify from a "
               "recording of the transducer (panelbass identify linear --data rec.wav) and upload the model");
  }
  ParamReader r(params, path);
  const std::string signal = r.choice("signal", "noise", {"noise", "multisine", "control"});
  const long long samples = r.integer("samples", 10000, kMinSamples, kMaxSamples);
  const long long validation = r.integer("validation_samples", 5000, 0, kMaxSamples);
  if (validation > 0 && validation < kMinSamples) {
    fail(r.path_of("validation_samples"), "must be 0 (none) or at least " + std::to_string(kMinSamples) + ", got " +
                                              std::to_string(validation));
  }
  r.number("amplitude", 0.3, {0.0, 1.0, true, false});
  r.integer("seed", 1, 0, kMaxSeed);
  // The plant in its operating regime (panelbass simulate --signal control): the LQ feedforward's output
  // for the controller design's program, noise then stepped sines, with per-sample harmonic weights.
  if (signal == "control") {
    if (samples < models::kMinControlSamples) {
      fail(r.path_of("samples"), "a control excitation needs at least " + std::to_string(models::kMinControlSamples) +
                                     " samples, got " + std::to_string(samples));
    }
    if (validation > 0 && validation < models::kMinControlSamples) {
      fail(r.path_of("validation_samples"), "must be 0 (none) or at least " + std::to_string(models::kMinControlSamples) +
                                                " for a control excitation, got " + std::to_string(validation));
    }
    stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
    const models::FeedbackDesignOptions design;
    r.number("sine_peak", design.sine_peak, {0.0, 1.0, true, false});
    r.number("program_share", design.program_share, {0.0, 1.0, false, false});
  }
  return r.finish();
}

// Where the data of an identify/analyze/diagnose job comes from: "record" (a succeeded excite job) or
// "excite" (an excitation of its own, the default). Fills exactly one of them; returns the validation
// samples the job will have, and in `validation_path` the field to name when they are missing.
long long record_source(ParamReader& r, const JobEnvironment& env, std::string& validation_path) {
  const json* record = r.member("record");
  const json* excite = r.member("excite");
  if (record != nullptr && excite != nullptr) {
    fail(r.path_of("record"), "give either \"record\" or \"excite\", not both");
  }
  if (record != nullptr) {
    const std::string where = r.path_of("record");
    if (!record->is_string()) fail(where, "expected the id of a finished excite job, got " + shown(*record));
    const std::string id = record->get<std::string>();
    if (!is_valid_id(id)) fail(where, "not a job id: " + shown(*record));
    const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
    if (!result) fail(where, "no succeeded job \"" + id + "\" (the record must name a finished excite job)");
    const ExcitationRecord data = excitation_record_from_result(*result, env.fs, where + ": job " + id);
    r.set("record", id);
    validation_path = where;
    return data.u_val.size();
  }
  const json filled = excite_params(excite != nullptr ? *excite : json::object(), r.path_of("excite"), env);
  r.set("excite", filled);
  validation_path = r.path_of("excite") + ".validation_samples";
  return filled.at("validation_samples").get<long long>();
}

// Hidden layer widths of a network.
std::vector<long long> hidden_layers(ParamReader& r, const std::vector<long long>& fallback) {
  return r.integers("hidden", fallback, 1, 4, 1, 256);
}

// ----- the kinds ------------------------------------------------------------------------------------

json identify_linear_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  const std::string method = r.choice("method", "oe", {"fir", "arx", "oe", "zhu", "backx"});
  r.integer("order", 8, 1, method == "fir" ? kMaxFirTaps : kMaxOrder);
  r.integer("delay", -1, -1, 1000);
  const json* scan = r.member("scan");
  if (scan == nullptr || scan->is_null()) {
    r.set("scan", nullptr);
  } else {
    const std::vector<long long> range = r.integers("scan", {}, 2, 2, 1, kMaxOrder);
    if (range[0] > range[1]) fail(r.path_of("scan"), "expected [from, to] with from <= to, got " + shown(*scan));
    if (validation == 0) fail(r.path_of("scan"), "an order scan needs validation data (" + validation_path + " has none)");
  }
  r.integer("max_iterations", 100, 1, kMaxIterations);
  return r.finish();
}

// True when the succeeded excite job `id` recorded harmonic weights (a control excitation).
bool record_has_weights(const JobEnvironment& env, const std::string& id) {
  const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
  return result && result->contains("record") && result->at("record").contains("w_est");
}

json identify_narx_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  record_source(r, env, validation_path);
  r.integer("na", 2, 0, kMaxOrder);
  r.integer("nb", 3, 0, kMaxOrder);
  r.integer("nk", -1, -1, 1000);
  const std::vector<long long> hidden = hidden_layers(r, {8});
  r.choices("modes", {"pem", "oem-d"}, {"pem", "oem-s", "oem-d", "oem-n"});
  r.integer("max_iterations", 30, 0, kMaxIterations);
  r.integer("seed", 1, 0, kMaxSeed);
  // The control excitation's harmonic weights in the loss (identify narx --weight-col w).
  if (r.boolean("weighted", false)) {
    const json* excite = r.member("excite");
    const json* record = r.member("record");
    const bool has_weights = record != nullptr ? record_has_weights(env, record->get<std::string>())
                                               : excite != nullptr && excite->value("signal", "") == "control";
    if (!has_weights) {
      fail(r.path_of("weighted"), "the weights come with a control excitation (excite.signal \"control\"), and " +
                                      (record != nullptr ? "job " + record->get<std::string>() + "'s record has none"
                                                         : std::string("this job's excitation is not one")));
    }
  }
  // Hidden nodes seeded as Coulomb friction (models::seed_friction_units): one per gain and lag.
  const std::vector<double> gains = r.numbers("friction_units", {}, 0, 16, {0.0, 1000.0, true, false});
  const long long lags = r.integer("friction_lags", 1, 1, 20);
  if (static_cast<long long>(gains.size()) * lags > hidden[0]) {
    fail(r.path_of("friction_units"), std::to_string(gains.size()) + " gains x " + std::to_string(lags) +
                                          " lags need as many first-layer nodes, hidden[0] is " + std::to_string(hidden[0]));
  }
  return r.finish();
}

json design_lq_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  stored_model(r, "plant_model", true, {"linear"}, env);
  const json* weight = r.member("r");
  const bool weight_given = weight != nullptr && !weight->is_null();
  r.number("r", 1e-5, {0.0, std::numeric_limits<double>::infinity(), true, true});
  // The weight chosen by its safe program amplitude instead (models::design_lq_for_input).
  if (const json* target = r.member("max_input"); target != nullptr && !target->is_null()) {
    if (weight_given) fail(r.path_of("max_input"), "choose the weight by r or by max_input, not both");
    r.number("max_input", 0.0, {0.0, 1.0, true, false});
  }
  const json* band = r.member("band_pass");
  ParamReader b(band != nullptr ? *band : json::object(), r.path_of("band_pass"));
  const double low = b.number("low_hz", 20.0, {0.0, std::numeric_limits<double>::infinity(), false, true});
  b.number("high_hz", 1200.0, {low, env.fs / 2.0, true, true});
  b.integer("order", 2, 1, 16);
  r.set("band_pass", b.finish());
  return r.finish();
}

json design_nn_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  stored_model(r, "plant_model", true, {"narx"}, env);
  stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  const models::FeedbackDesignOptions design;
  r.integer("samples", 3000, 1000, kMaxSamples);
  r.integer("max_iterations", 20, 0, kMaxIterations);
  hidden_layers(r, {6});
  r.integer("nu", design.structure.nu, 0, kMaxControllerLag);
  r.integer("nv", design.structure.nv, 0, kMaxControllerLag);
  r.integer("ny", design.structure.ny, 0, kMaxControllerLag);
  r.number("sine_share", design.sine_share, {0.0, 1.0, false, false});
  r.number("sine_peak", design.sine_peak, {0.0, 1.0, true, false});
  r.number("program_share", design.program_share, {0.0, 1.0, false, false});
  const std::string desired = r.choice("desired", models::desired_response_name(design.desired),
                                      {"linear-model", "plant-small-signal", "plant-fundamental"});
  const std::string weighting = r.choice("weighting", "none", {"none", "level", "distortion"});
  const long long restarts = r.integer("restarts", design.restarts, 1, kMaxRestarts);
  r.choice("keep", models::restart_choice_name(design.keep), {"validation-jc", "worst-probe"});
  r.numbers("probes_hz", models::evaluation_probe_hz(), 1, 16, {0.0, env.fs / 4.0, true, true});
  r.number("rail_penalty", design.training.rail_penalty, {0.0, kMaxRailPenalty, false, false});
  r.number("dc_penalty", design.training.dc_penalty, {0.0, kMaxRailPenalty, false, false});
  r.integer("seed", 1, 0, kMaxSeed);
  // Tuning on a device (panelbass design nn --tune-on): the server's own virtual transducer when it runs one,
  // or a preset; "none": the plant model alone. Training on from a stored controller (--start-from).
  std::vector<std::string> devices = models::plant_preset_names();
  if (env.plant) devices.insert(devices.begin(), "server");
  devices.insert(devices.begin(), "none");
  const std::string tune_on = r.choice("tune_on", "none", devices);
  const long long playbacks = r.integer("tune_playbacks", design.device_playbacks, 1, kMaxPlaybacks);
  stored_model(r, "start_from", false, {"neural_feedback"}, env);
  const json* start_from = r.member("start_from");
  if (tune_on == "none" && playbacks != 1) {
    fail(r.path_of("tune_playbacks"), "plays each drive into the device of tune_on, and tune_on is \"none\"");
  }
  if (tune_on != "none" && (desired != "plant-fundamental" || weighting == "level")) {
    fail(r.path_of("tune_on"), "tuning on the device asks only each sine step's harmonics of it: it needs desired "
                               "\"plant-fundamental\" and no level weighting");
  }
  if (start_from != nullptr && !start_from->is_null() && restarts != 1) {
    fail(r.path_of("start_from"), "training on from a controller is one training, and restarts is " +
                                      std::to_string(restarts));
  }
  return r.finish();
}

// A chain of stored controllers evaluated on a virtual transducer (panelbass evaluate).
json evaluate_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  stored_model(r, "feedback_model", false, {"neural_feedback"}, env);
  const std::string source = r.choice("source", "model", {"model", "sensor"});
  const json* feedback = r.member("feedback_model");
  if (source == "sensor" && (feedback == nullptr || feedback->is_null())) {
    fail(r.path_of("source"), "\"sensor\" is where a feedback stage takes its past outputs from, and there is no feedback_model");
  }
  // The server's own virtual transducer when it runs one, or a preset.
  std::vector<std::string> plants = models::plant_preset_names();
  if (env.plant) plants.insert(plants.begin(), "server");
  r.choice("plant", plants.front(), plants);
  const engine::EvaluationOptions defaults;
  r.numbers("probes_hz", defaults.probe_hz, 1, 16, {0.0, env.fs / 2.0, true, true});
  r.number("probe_peak", defaults.probe_peak, {0.0, 1.0, false, false});
  r.integer("noise_samples", defaults.noise_samples, 4096, kMaxSamples);
  r.integer("seed", 1, 0, kMaxSeed);
  r.boolean("attribute", false);
  return r.finish();
}

json analyze_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  stored_model(r, "model", true, {"linear", "narx"}, env);
  std::string validation_path;
  record_source(r, env, validation_path);
  return r.finish();
}

json diagnose_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  if (validation == 0) fail(validation_path, "diagnose needs validation data (it judges every augmentation on it)");
  stored_model(r, "baseline_model", false, {"linear", "narx"}, env);
  r.integer("max_findings", 4, 0, 20);
  return r.finish();
}

Eigen::VectorXd numbers_of(const json& record, const char* name, const std::string& where) {
  const auto it = record.find(name);
  if (it == record.end() || !it->is_array()) fail_after(where, std::string("has no array record.") + name);
  Eigen::VectorXd x(static_cast<Eigen::Index>(it->size()));
  Eigen::Index k = 0;
  for (const json& v : *it) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      fail_after(where, std::string("has a non-finite record.") + name + "[" + std::to_string(k) + "]");
    }
    x[k++] = v.get<double>();
  }
  return x;
}

json vector_json(const Eigen::VectorXd& x) { return std::vector<double>(x.data(), x.data() + x.size()); }

}  // namespace

// ----- Interval --------------------------------------------------------------------------------------

bool Interval::contains(double v) const {
  const bool above = lo_open ? v > lo : v >= lo;
  const bool below = hi_open ? v < hi : v <= hi;
  return above && below;
}

std::string Interval::text() const {
  return std::string(lo_open ? "(" : "[") + number_text(lo) + ", " + number_text(hi) + (hi_open ? ")" : "]");
}

// ----- ParamReader -----------------------------------------------------------------------------------

ParamReader::ParamReader(const json& params, std::string path)
    : params_(params.is_null() ? json::object() : params), path_(std::move(path)) {
  if (!params_.is_object()) fail(path_, "expected an object, got " + std::string(params_.type_name()));
}

const json* ParamReader::find(const std::string& key) {
  if (std::find(known_.begin(), known_.end(), key) == known_.end()) known_.push_back(key);
  const auto it = params_.find(key);
  return it == params_.end() ? nullptr : &*it;
}

std::string ParamReader::path_of(const std::string& key) const { return path_ + "." + key; }

long long ParamReader::integer(const std::string& key, long long fallback, long long lo, long long hi) {
  const json* v = find(key);
  long long value = fallback;
  if (v != nullptr) {
    const std::optional<long long> i = integral(*v);
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!i) fail(path_of(key), "must be an integer in " + range + ", got " + shown(*v));
    if (*i < lo || *i > hi) fail(path_of(key), "must be an integer in " + range + ", got " + std::to_string(*i));
    value = *i;
  }
  filled_[key] = value;
  return value;
}

double ParamReader::number(const std::string& key, double fallback, const Interval& range) {
  const json* v = find(key);
  double value = fallback;
  if (v != nullptr) {
    if (!v->is_number() || !std::isfinite(v->get<double>())) {
      fail(path_of(key), "must be a number in " + range.text() + ", got " + shown(*v));
    }
    value = v->get<double>();
    if (!range.contains(value)) fail(path_of(key), "must be a number in " + range.text() + ", got " + shown(*v));
  }
  filled_[key] = value;
  return value;
}

bool ParamReader::boolean(const std::string& key, bool fallback) {
  const json* v = find(key);
  if (v != nullptr && !v->is_boolean()) fail(path_of(key), "expected true or false, got " + shown(*v));
  const bool value = v != nullptr ? v->get<bool>() : fallback;
  filled_[key] = value;
  return value;
}

std::string ParamReader::choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& choices) {
  const json* v = find(key);
  std::string value = fallback;
  if (v != nullptr) {
    if (!v->is_string() || std::find(choices.begin(), choices.end(), v->get<std::string>()) == choices.end()) {
      fail(path_of(key), "must be one of " + list_text(choices) + ", got " + shown(*v));
    }
    value = v->get<std::string>();
  }
  filled_[key] = value;
  return value;
}

std::vector<long long> ParamReader::integers(const std::string& key, const std::vector<long long>& fallback,
                                             std::size_t min_count, std::size_t max_count, long long lo, long long hi) {
  const json* v = find(key);
  std::vector<long long> values = fallback;
  if (v != nullptr) {
    const std::string expected = (min_count == max_count ? std::to_string(min_count)
                                                         : std::to_string(min_count) + " to " + std::to_string(max_count)) +
                                 " integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!v->is_array() || v->size() < min_count || v->size() > max_count) {
      fail(path_of(key), "must be a list of " + expected + ", got " + shown(*v));
    }
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const std::optional<long long> i = integral((*v)[k]);
      if (!i || *i < lo || *i > hi) {
        fail(path_of(key) + "[" + std::to_string(k) + "]", "must be an integer in [" + std::to_string(lo) + ", " +
                                                                std::to_string(hi) + "], got " + shown((*v)[k]));
      }
      values.push_back(*i);
    }
  }
  filled_[key] = values;
  return values;
}

std::vector<double> ParamReader::numbers(const std::string& key, const std::vector<double>& fallback,
                                         std::size_t min_count, std::size_t max_count, const Interval& range) {
  const json* v = find(key);
  std::vector<double> values = fallback;
  if (v != nullptr) {
    if (!v->is_array() || v->size() < min_count || v->size() > max_count) {
      fail(path_of(key), "must be a list of " + std::to_string(min_count) + " to " + std::to_string(max_count) +
                             " numbers in " + range.text() + ", got " + shown(*v));
    }
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const json& e = (*v)[k];
      if (!e.is_number() || !std::isfinite(e.get<double>()) || !range.contains(e.get<double>())) {
        fail(path_of(key) + "[" + std::to_string(k) + "]", "must be a number in " + range.text() + ", got " + shown(e));
      }
      values.push_back(e.get<double>());
    }
  }
  filled_[key] = values;
  return values;
}

std::vector<std::string> ParamReader::choices(const std::string& key, const std::vector<std::string>& fallback,
                                              const std::vector<std::string>& choices) {
  const json* v = find(key);
  std::vector<std::string> values = fallback;
  if (v != nullptr) {
    if (!v->is_array() || v->empty()) fail(path_of(key), "must be a non-empty list of " + list_text(choices) + ", got " + shown(*v));
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const json& e = (*v)[k];
      if (!e.is_string() || std::find(choices.begin(), choices.end(), e.get<std::string>()) == choices.end()) {
        fail(path_of(key) + "[" + std::to_string(k) + "]", "must be one of " + list_text(choices) + ", got " + shown(e));
      }
      values.push_back(e.get<std::string>());
    }
  }
  filled_[key] = values;
  return values;
}

std::optional<std::string> ParamReader::id(const std::string& key, bool required) {
  const json* v = find(key);
  if (v == nullptr || v->is_null()) {
    if (required) fail(path_of(key), "required");
    filled_[key] = nullptr;
    return std::nullopt;
  }
  if (!v->is_string() || !is_valid_id(v->get<std::string>())) {
    fail(path_of(key), "must be an id (letters, digits, _ or -), got " + shown(*v));
  }
  filled_[key] = *v;
  return v->get<std::string>();
}

const json* ParamReader::member(const std::string& key) { return find(key); }

void ParamReader::set(const std::string& key, json value) {
  find(key);
  filled_[key] = std::move(value);
}

json ParamReader::finish() const {
  for (auto it = params_.begin(); it != params_.end(); ++it) {
    if (std::find(known_.begin(), known_.end(), it.key()) == known_.end()) fail(path_of(it.key()), "unknown field");
  }
  return filled_;
}

// ----- records and kinds -----------------------------------------------------------------------------

json excitation_record_to_json(const ExcitationRecord& record) {
  json out = {{"u_est", vector_json(record.u_est)},
              {"y_est", vector_json(record.y_est)},
              {"u_val", vector_json(record.u_val)},
              {"y_val", vector_json(record.y_val)}};
  if (record.w_est.size() > 0) {
    out["w_est"] = vector_json(record.w_est);
    out["w_val"] = vector_json(record.w_val);
  }
  return out;
}

ExcitationRecord excitation_record_from_result(const json& result, double fs, const std::string& where) {
  if (!result.is_object() || !result.contains("record") || !result.at("record").is_object()) {
    fail_after(where, "is not an excite job (its result has no \"record\")");
  }
  const json& record = result.at("record");
  ExcitationRecord out;
  out.u_est = numbers_of(record, "u_est", where);
  out.y_est = numbers_of(record, "y_est", where);
  out.u_val = numbers_of(record, "u_val", where);
  out.y_val = numbers_of(record, "y_val", where);
  if (out.u_est.size() != out.y_est.size() || out.u_val.size() != out.y_val.size()) {
    fail_after(where, "has a record whose drive and response differ in length");
  }
  if (record.contains("w_est")) {
    out.w_est = numbers_of(record, "w_est", where);
    out.w_val = numbers_of(record, "w_val", where);
    if (out.w_est.size() != out.u_est.size() || out.w_val.size() != out.u_val.size()) {
      fail_after(where, "has a record whose weights and drive differ in length");
    }
    if ((out.w_est.array() < 0.0).any() || (out.w_val.array() < 0.0).any()) {
      fail_after(where, "has a record with a negative weight");
    }
  }
  if (out.u_est.size() < kMinSamples) {
    fail_after(where, "has a record of " + std::to_string(out.u_est.size()) + " estimation samples, fewer than " +
                          std::to_string(kMinSamples));
  }
  const auto rate = result.find("fs");
  if (rate != result.end() && (!rate->is_number() || std::abs(rate->get<double>() - fs) > 1e-9 * fs)) {
    fail_after(where, "was recorded at " + shown(*rate) + " Hz, the engine runs at " + number_text(fs) + " Hz");
  }
  return out;
}

json validate_kind_params(const std::string& kind, const json& params, const JobEnvironment& env) {
  if (kind == "excite") return excite_params(params, "params", env);
  if (kind == "identify-linear") return identify_linear_params(params, env);
  if (kind == "identify-narx") return identify_narx_params(params, env);
  if (kind == "design-lq") return design_lq_params(params, env);
  if (kind == "design-nn") return design_nn_params(params, env);
  if (kind == "evaluate") return evaluate_params(params, env);
  if (kind == "analyze") return analyze_params(params, env);
  if (kind == "diagnose") return diagnose_params(params, env);
  std::string expected;
  for (const std::string& k : job_kinds()) expected += (expected.empty() ? "" : ", ") + k;
  fail("kind", "unknown job kind \"" + kind + "\"; expected one of " + expected);
}

}  // namespace panelbass::api
