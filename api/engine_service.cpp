#include "api/engine_service.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/sample_rate.h"
#include "api/alsa_status_json.h"
#include "api/program_request.h"
#include "models/io/config_error.h"
#include "models/io/number_text.h"
#include "models/kinds/model_file.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::api {
namespace {

constexpr std::array<const char*, 2> kSlotKeys = {"feedforward", "feedback"};
// "chain.band_pass.low_hz: …" (the chain file's wording) → "config.band_pass.low_hz: …".
std::string as_config_message(const std::string& message) {
  const std::string prefix = "chain.";
  return message.rfind(prefix, 0) == 0 ? "config." + message.substr(prefix.size()) : message;
}

nlohmann::json change_json(const engine::ConfigChange& change) {
  nlohmann::json keys = nlohmann::json::array();
  for (const auto& d : change.differences) keys.push_back(d.key);
  return {{"kind", engine::change_class_name(change.kind)}, {"keys", keys}};
}

std::string keys_needing_restart(const engine::ConfigChange& change) {
  std::string keys;
  for (const auto& d : change.differences) {
    if (d.kind != engine::ChangeClass::restart) continue;
    keys += (keys.empty() ? "" : ", ") + d.key;
  }
  return keys;
}

// The registry's role of slot `s` (0 feedforward, 1 feedback).
models::ModelRole slot_role(std::size_t s) { return s == 0 ? models::ModelRole::feedforward : models::ModelRole::feedback; }

// Why model `id` of `kind` cannot go into slot `s` (nullopt: it can), in the registry's words.
std::optional<std::string> slot_refusal(std::size_t s, const std::string& id, const std::string& kind) {
  const models::ModelKind* known = models::find_model_kind(kind);
  if (known == nullptr) return "model \"" + id + "\" is of kind \"" + kind + "\", which no slot runs";
  try {
    models::require_role(*known, slot_role(s), "model \"" + id + "\"");
  } catch (const models::ConfigError& e) {
    return std::string(e.what());
  }
  return std::nullopt;
}

// The first key of `whole` (the running settings, recursively) that `settings` leaves out, as
// "config.band_pass.order"; nullopt if none. `fs`, `block` and `history` may be left out.
std::optional<std::string> first_missing_key(const nlohmann::json& whole, const nlohmann::json& settings,
                                             const std::string& path) {
  if (!settings.is_object()) return std::nullopt;  // a wrong type: the chain file's reader names it
  for (const auto& [key, value] : whole.items()) {
    if (path == "config" && (key == "fs" || key == "block" || key == "history")) continue;
    const auto it = settings.find(key);
    if (it == settings.end()) return path + "." + key;
    if (value.is_object()) {
      if (auto missing = first_missing_key(value, *it, path + "." + key)) return missing;
    }
  }
  return std::nullopt;
}

// The chain-file object of API settings: format tag added, fs/block/history filled in from `running`,
// slot models looked up by id and written inline (a null model leaves the slot out). The ids chosen go to
// `ids`.
nlohmann::json chain_json_of(const nlohmann::json& settings, const engine::ChainConfig& running,
                             const ModelLookup& lookup, std::array<std::optional<std::string>, 2>& ids) {
  if (!settings.is_object()) throw EngineRequestError(400, "bad_request", "config: expected a JSON object");
  if (settings.contains("format")) {
    throw EngineRequestError(400, "bad_request", "config.format: unknown field (the API's settings carry no format tag)");
  }
  nlohmann::json chain = settings;
  chain["format"] = engine::kChainFormat;
  if (!chain.contains("fs")) chain["fs"] = running.fs;
  if (!chain.contains("block")) chain["block"] = running.block;
  if (!chain.contains("history")) chain["history"] = running.history;
  for (std::size_t s = 0; s < kSlotKeys.size(); ++s) {
    const std::string key = kSlotKeys[s];
    ids[s].reset();
    if (!chain.contains(key)) continue;
    nlohmann::json& slot = chain[key];
    if (!slot.is_object()) throw EngineRequestError(400, "bad_request", "config." + key + ": expected an object");
    if (!slot.contains("model") || slot["model"].is_null()) {
      chain.erase(key);
      continue;
    }
    if (!slot["model"].is_string()) {
      throw EngineRequestError(400, "bad_request", "config." + key + ".model: expected a stored model id or null");
    }
    const std::string id = slot["model"].get<std::string>();
    std::optional<nlohmann::json> model = lookup(id);
    if (!model) throw EngineRequestError(400, "bad_request", "config." + key + ".model: no stored model \"" + id + "\"");
    const std::string kind = model->value("kind", "");
    if (auto refusal = slot_refusal(s, id, kind)) throw EngineRequestError(409, "conflict", "config." + key + ".model: " + *refusal);
    slot["model"] = std::move(*model);
    ids[s] = id;
  }
  return chain;
}

}  // namespace

const char* slot_name(ModelSlotName slot) { return kSlotKeys[static_cast<std::size_t>(slot)]; }

std::vector<ModelSlotName> slots_accepting(const std::string& kind) {
  std::vector<ModelSlotName> slots;
  const models::ModelKind* known = models::find_model_kind(kind);
  for (const ModelSlotName slot : {ModelSlotName::feedforward, ModelSlotName::feedback}) {
    if (known != nullptr && known->takes(slot_role(static_cast<std::size_t>(slot)))) slots.push_back(slot);
  }
  return slots;
}

std::optional<ModelSlotName> default_slot(const std::string& kind) {
  const std::vector<ModelSlotName> slots = slots_accepting(kind);
  if (slots.empty()) return std::nullopt;
  return slots.front();
}

ModelSlotName slot_for(const std::string& id, const std::string& kind) {
  if (const std::optional<ModelSlotName> slot = default_slot(kind)) return *slot;
  require_slot_accepts(ModelSlotName::feedforward, id, kind);  // throws, naming the kind and what slots take
  return ModelSlotName::feedforward;
}

void require_slot_accepts(ModelSlotName slot, const std::string& id, const std::string& kind) {
  if (auto refusal = slot_refusal(static_cast<std::size_t>(slot), id, kind)) {
    throw EngineRequestError(409, "conflict", *refusal);
  }
}

ModelSlotName parse_slot_name(const std::string& name) {
  if (name == "feedforward") return ModelSlotName::feedforward;
  if (name == "feedback") return ModelSlotName::feedback;
  throw EngineRequestError(400, "bad_request", "slot: expected \"feedforward\" or \"feedback\", got \"" + name + "\"");
}

EngineService::EngineService(EngineServiceOptions options) : options_(std::move(options)) {
  if (!dsp::same_rate(options_.plant.fs, options_.chain.fs)) {
    throw std::invalid_argument("engine: the plant runs at " + models::number_text(options_.plant.fs) +
                                " Hz, the chain at " + models::number_text(options_.chain.fs) + " Hz");
  }
  if (options_.chain.feedforward || options_.chain.feedback) {
    throw std::invalid_argument("engine: the service starts with empty model slots; activate stored models instead");
  }
  running_ = options_.chain;
  chain_ = engine::make_chain(running_);
  const std::vector<double>& initial = options_.alsa ? options_.alsa->program : options_.program;
  program_ = options_.program_description.is_object()
                 ? options_.program_description
                 : nlohmann::json{{"signal", initial.empty() ? "silence" : "custom"}};
  if (options_.alsa) {
    std::vector<double> program = std::move(options_.alsa->program);  // the player keeps the one copy
    engine::AlsaOptions card = *options_.alsa;
    card.program = std::move(program);
    card.program_fade_s = options_.program_fade_s;
    alsa_ = std::make_unique<engine::AlsaBackend>(*chain_, std::move(card));
    return;
  }
  engine::VirtualBackendOptions backend;
  backend.block = engine::Samples{running_.block};
  backend.pacing = options_.pacing;
  backend.program = std::move(options_.program);
  backend.loop = true;
  backend.plant = options_.plant;
  backend.noise_seed = options_.seed;
  backend.realtime_priority = options_.realtime_priority;
  backend.program_fade_s = options_.program_fade_s;
  backend.on_block = options_.on_block;
  backend_ = std::make_unique<engine::VirtualBackend>(*chain_, std::move(backend));
}

EngineService::~EngineService() { stop(); }

void EngineService::start() {
  const std::lock_guard lock(mutex_);
  if (playing_) return;
  if (alsa_) {
    alsa_->start();
  } else {
    backend_->start();
  }
  playing_ = true;
  started_ = std::chrono::steady_clock::now();
}

void EngineService::stop() {
  const std::lock_guard lock(mutex_);
  if (!playing_) return;
  if (alsa_) {
    alsa_->stop();
  } else {
    backend_->stop();
  }
  playing_ = false;
  chain_->collect_retired();
}

void EngineService::housekeeping() {
  using clock = std::chrono::steady_clock;
  const std::lock_guard lock(mutex_);
  chain_->collect_retired();
  if (engine::ProgramPlayer* player = program_player()) player->collect_retired();
  const clock::time_point now = clock::now();
  const engine::MetricsSnapshot m = chain_->metrics().snapshot();
  limiter_samples_.push_back({now, m.samples, m.limited_samples, m.over_range_samples});
  // Keep one tick at least a second old as the window's start.
  while (limiter_samples_.size() > 2 && now - limiter_samples_[1].at >= std::chrono::seconds(1)) {
    limiter_samples_.pop_front();
  }
  if (!chain_->in_fault()) {
    fault_since_.reset();
    return;
  }
  if (!fault_since_) {
    // A fault soon after the last recovery: it came back, so wait longer this time.
    const bool came_back = recoveries_ > 0 && now - last_recovery_ < std::chrono::seconds(10);
    hold_s_ = came_back ? std::min(2.0 * hold_s_, 30.0) : 1.0;
    fault_since_ = now;
  }
  if (std::chrono::duration<double>(now - *fault_since_).count() >= hold_s_) {
    chain_->clear_fault();
    ++recoveries_;
    last_recovery_ = now;
    fault_since_.reset();
  }
}

nlohmann::json EngineService::engine_status() const {
  const std::lock_guard lock(mutex_);
  const double uptime =
      playing_ ? std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count() : 0.0;
  nlohmann::json status = {{"state", playing_ ? "running" : "stopped"},
                            {"backend", alsa_ ? "alsa" : "virtual"},
                            {"plant", options_.plant.name},
                            {"fs", running_.fs},
                            {"block", running_.block},
                            {"uptime_s", uptime},
                            {"realtime", alsa_ ? alsa_->status().realtime : backend_->realtime()},
                            {"recoveries", recoveries_},
                            {"fault_hold_s", hold_s_}};
  if (alsa_) status["device"] = api::alsa_status_to_json(alsa_->status(), alsa_->resampling_latency());
  return status;
}

engine::ProgramPlayer* EngineService::program_player() const {
  if (!alsa_) return &backend_->program();
  return alsa_->options().program_channel == engine::kNoChannel ? &alsa_->program() : nullptr;
}

nlohmann::json EngineService::program() const {
  const std::lock_guard lock(mutex_);
  nlohmann::json p = program_;
  const engine::ProgramPlayer* player = program_player();
  if (player == nullptr) {
    return {{"signal", "capture"},
            {"source", "capture"},
            {"channel", alsa_->options().program_channel},
            {"settled", true}};
  }
  p["source"] = "memory";
  p["rate"] = alsa_ ? alsa_->options().rate.value : running_.fs;
  p["fade_s"] = options_.program_fade_s;
  p["settled"] = player->idle();
  return p;
}

nlohmann::json EngineService::put_program(const nlohmann::json& request) {
  {
    const std::lock_guard lock(mutex_);
    engine::ProgramPlayer* player = program_player();
    if (player == nullptr) {
      throw EngineRequestError(409, "conflict",
                               "program: the program comes from the card's capture channel " +
                                   std::to_string(alsa_->options().program_channel) +
                                   " (serve --program-channel), not from memory; play it at the source instead");
    }
    const ProgramRequest r = parse_program_request(request, running_.fs, safe_level());
    engine::LoopedSignal played = program_samples(r, alsa_ ? alsa_->options().rate.value : running_.fs);
    program_ = program_json(r, played);
    player->install(std::move(played.samples));
  }
  return program();
}

std::optional<engine::AlsaStatus> EngineService::device_status() const {
  if (!alsa_) return std::nullopt;
  return alsa_->status();
}

engine::MetricsSnapshot EngineService::metrics() const { return chain_->metrics().snapshot(); }

LimiterActivity EngineService::limiter_activity() const {
  const std::lock_guard lock(mutex_);
  LimiterActivity a;
  if (limiter_samples_.size() < 2) return a;
  const LimiterSample& first = limiter_samples_.front();
  const LimiterSample& last = limiter_samples_.back();
  a.window_s = std::chrono::duration<double>(last.at - first.at).count();
  if (last.samples > first.samples) {
    const auto samples = static_cast<double>(last.samples - first.samples);
    // Shares of the samples: a stage's own count joins the limiter's, so the sum can exceed the samples.
    a.limited_fraction = std::min(1.0, static_cast<double>(last.limited - first.limited) / samples);
    a.over_range_fraction = std::min(1.0, static_cast<double>(last.over_range - first.over_range) / samples);
  }
  a.needs_more_drive = last.over_range > first.over_range;
  return a;
}

std::optional<std::string> EngineService::active_model(ModelSlotName slot) const {
  const std::lock_guard lock(mutex_);
  return active_ids_[static_cast<std::size_t>(slot)];
}

engine::ChainConfig EngineService::running_chain() const {
  const std::lock_guard lock(mutex_);
  return running_;
}

nlohmann::json EngineService::config() const {
  const std::lock_guard lock(mutex_);
  return api_settings();
}

nlohmann::json EngineService::api_settings() const {
  // Caller holds mutex_.
  nlohmann::json j = engine::chain_config_to_json(running_);
  j.erase("format");
  const std::array<const std::optional<engine::SlotConfig>*, 2> slots = {&running_.feedforward, &running_.feedback};
  for (std::size_t s = 0; s < slots.size(); ++s) {
    const std::optional<engine::SlotConfig>& slot = *slots[s];
    nlohmann::json out = {{"model", active_ids_[s] ? nlohmann::json(*active_ids_[s]) : nlohmann::json(nullptr)},
                          {"bypass", slot && slot->bypass}};
    if (s == 1) out["source"] = slot && slot->source == engine::FeedbackSource::sensor ? "sensor" : "model";
    j[kSlotKeys[s]] = out;
  }
  return j;
}

nlohmann::json EngineService::apply(const nlohmann::json& settings, const ModelLookup& lookup) {
  // Caller holds mutex_.
  // A change of the rate, block or history needs a restart whatever else the settings say (the slot
  // models and the band-pass would otherwise be refused first for not suiting the new rate).
  if (settings.is_object()) {
    const std::array<std::pair<const char*, double>, 3> fixed = {
        {{"fs", running_.fs}, {"block", static_cast<double>(running_.block)}, {"history", static_cast<double>(running_.history)}}};
    std::string changed;
    for (const auto& [key, value] : fixed) {
      const auto it = settings.find(key);
      if (it != settings.end() && it->is_number() && it->get<double>() != value) {
        changed += (changed.empty() ? "" : ", ") + std::string(key) + " (" + models::number_text(value) + " → " +
                   models::number_text(it->get<double>()) + ")";
      }
    }
    if (!changed.empty()) {
      throw EngineRequestError(409, "conflict",
                               "config: " + changed + " cannot change while the engine plays (a restart of panelbass "
                               "serve is needed)");
    }
  }
  std::array<std::optional<std::string>, 2> ids;
  const nlohmann::json chain = chain_json_of(settings, running_, lookup, ids);
  engine::ChainConfig next;
  try {
    next = engine::chain_config_from_json(chain, ".");
  } catch (const models::ConfigError& e) {
    throw EngineRequestError(400, "bad_request", as_config_message(e.what()));
  }
  const engine::ConfigChange change = engine::classify_change(running_, next);
  if (change.kind == engine::ChangeClass::restart) {
    throw EngineRequestError(409, "conflict",
                             "config: " + keys_needing_restart(change) +
                                 " cannot change while the engine plays (a restart of panelbass serve is needed)");
  }
  try {
    engine::apply_change(*chain_, running_, next);
  } catch (const std::invalid_argument& e) {
    throw EngineRequestError(400, "bad_request", as_config_message(e.what()));
  }
  running_ = std::move(next);
  active_ids_ = ids;
  return change_json(change);
}

nlohmann::json EngineService::running_settings() const {
  // Caller holds mutex_. The chain file's form of what runs, models named by their store ids.
  nlohmann::json settings = engine::chain_config_to_json(running_);
  settings.erase("format");
  for (std::size_t s = 0; s < kSlotKeys.size(); ++s) {
    if (settings.contains(kSlotKeys[s])) settings[kSlotKeys[s]]["model"] = *active_ids_[s];
  }
  return settings;
}

nlohmann::json EngineService::put_config(const nlohmann::json& settings, const ModelLookup& lookup) {
  const std::lock_guard lock(mutex_);
  if (auto missing = first_missing_key(api_settings(), settings, "config")) {
    throw EngineRequestError(400, "bad_request",
                             *missing + ": missing (PUT /api/config takes the whole settings object, as GET returns "
                                        "it; PATCH /api/config changes a part)");
  }
  return apply(settings, lookup);
}

nlohmann::json EngineService::patch_config(const nlohmann::json& patch, const ModelLookup& lookup) {
  if (!patch.is_object()) throw EngineRequestError(400, "bad_request", "config: a merge patch must be a JSON object");
  const std::lock_guard lock(mutex_);
  nlohmann::json settings = running_settings();
  settings.merge_patch(patch);
  return apply(settings, lookup);
}

nlohmann::json EngineService::activate(ModelSlotName slot, const std::string& id, const nlohmann::json& model) {
  require_slot_accepts(slot, id, model.is_object() ? model.value("kind", "") : "");
  const std::lock_guard lock(mutex_);
  nlohmann::json settings = running_settings();
  const std::string key = slot_name(slot);
  if (!settings.contains(key)) settings[key] = nlohmann::json::object();
  settings[key]["model"] = id;
  const ModelLookup lookup = [&](const std::string& wanted) -> std::optional<nlohmann::json> {
    if (wanted == id) return model;
    for (std::size_t s = 0; s < kSlotKeys.size(); ++s) {
      if (active_ids_[s] == wanted) {
        const auto& running = s == 0 ? running_.feedforward : running_.feedback;
        if (running) return running->model;
      }
    }
    return std::nullopt;
  };
  return apply(settings, lookup);
}

Eigen::VectorXd EngineService::excite(const Eigen::VectorXd& drive) {
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    if (!std::isfinite(drive[k]) || std::abs(drive[k]) > 1.0) {
      throw std::invalid_argument("excite: drive sample " + std::to_string(k) + " is " +
                                  models::number_text(drive[k]) + ", outside [-1, 1]");
    }
  }
  if (alsa_) {
    if (options_.alsa->sensor_channel == engine::kNoChannel) {
      throw EngineRequestError(409, "conflict", "excite: the card captures no sensor (panelbass serve --sensor-channel)");
    }
    return measure(drive).sensor;
  }
  std::uint64_t seed = 0;
  {
    const std::lock_guard lock(mutex_);
    seed = options_.seed + 1 + excitations_++;
  }
  return models::simulate(options_.plant, drive, seed).y;
}

}  // namespace panelbass::api
