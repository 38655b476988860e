#include "engine/chain_file.h"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "dsp/sample_rate.h"
#include "engine/stage_factory.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"
#include "models/io/number_text.h"

namespace panelbass::engine {
namespace {

using models::ConfigError;
using models::JsonFields;

std::string show(double v) { return models::number_text(v); }

// Milliseconds to whole samples at `fs`.
int to_samples(double ms, double fs) { return static_cast<int>(std::lround(ms * fs / 1000.0)); }

bool same_design(const BandPassDesign& a, const BandPassDesign& b) {
  return a.low.value == b.low.value && a.high.value == b.high.value && a.order == b.order;
}

bool same_slot(const std::optional<SlotConfig>& a, const std::optional<SlotConfig>& b) {
  if (a.has_value() != b.has_value()) return false;
  if (!a) return true;
  return a->path == b->path && a->model == b->model && a->source == b->source && a->bypass == b->bypass;
}

const char* source_name(FeedbackSource source) { return source == FeedbackSource::sensor ? "sensor" : "model"; }

BandPassConfig parse_band_pass(const nlohmann::json& value, double fs) {
  JsonFields f(value, "chain.band_pass");
  BandPassConfig c;
  const double nyquist = fs / 2.0;
  const double low = f.number("low_hz", c.design.low.value);
  const double high = f.number("high_hz", c.design.high.value);
  if (!(high > 0.0 && high < nyquist)) {
    throw ConfigError(f.path_of("high_hz") + ": must be within (0, fs/2 = " + show(nyquist) + ") Hz, got " + show(high));
  }
  if (!(low >= 0.0 && low < nyquist)) {
    throw ConfigError(f.path_of("low_hz") + ": must be within [0, fs/2 = " + show(nyquist) +
                      ") Hz (0 = low-pass only), got " + show(low));
  }
  if (!(low < high)) {
    throw ConfigError(f.path_of("low_hz") + ": must be below high_hz = " + show(high) + " Hz, got " + show(low));
  }
  c.design.low = Hertz{low};
  c.design.high = Hertz{high};
  c.design.order = static_cast<int>(f.integer("order", c.design.order, 1, 16));
  c.bypass = f.boolean("bypass", false);
  f.finish();
  return c;
}

// The role of the feedforward or the feedback slot, as the model-kind registry names it.
models::ModelRole slot_role(bool feedback) { return feedback ? models::ModelRole::feedback : models::ModelRole::feedforward; }

// The model of a slot: a path relative to `folder` or an inline object; validated as a stage at `fs`.
SlotConfig parse_slot(const nlohmann::json& value, const std::string& name, double fs,
                      const std::filesystem::path& folder, bool feedback) {
  JsonFields f(value, "chain." + name);
  SlotConfig c;
  const std::string model_key = f.path_of("model");
  const nlohmann::json* model = f.member("model");
  if (model == nullptr) throw ConfigError(model_key + ": missing (a model file path or a model object)");
  if (model->is_string()) {
    c.path = model->get<std::string>();
    if (c.path.empty()) throw ConfigError(model_key + ": empty path");
    try {
      c.model = models::read_json_file(folder / c.path);
    } catch (const std::exception& e) {
      throw ConfigError(model_key + ": " + e.what());
    }
  } else if (model->is_object()) {
    c.model = *model;
  } else {
    throw ConfigError(model_key + ": expected a path or a model object, got " + std::string(model->type_name()));
  }
  if (feedback) {
    const std::string source = f.string("source", "model");
    if (source == "model") {
      c.source = FeedbackSource::model;
    } else if (source == "sensor") {
      c.source = FeedbackSource::sensor;
    } else {
      throw ConfigError(f.path_of("source") + ": expected \"model\" or \"sensor\", got \"" + source + "\"");
    }
  }
  c.bypass = f.boolean("bypass", false);
  f.finish();
  // make_stage() validates the object and knows which kinds the slot runs.
  const std::string where = c.path.empty() ? model_key : model_key + " (" + (folder / c.path).string() + ")";
  try {
    (void)make_stage(c.model, slot_role(feedback), c.source);
  } catch (const std::exception& e) {
    throw ConfigError(where + ": " + e.what());
  }
  double model_fs = 0.0;
  try {
    model_fs = model_rate(c.model);
  } catch (const std::exception& e) {
    throw ConfigError(where + ": " + e.what());
  }
  if (!dsp::same_rate(model_fs, fs)) {
    throw ConfigError(where + ": the model runs at fs = " + show(model_fs) + " Hz, the chain at chain.fs = " +
                      show(fs) + " Hz");
  }
  return c;
}

LimiterConfig parse_limiter(const nlohmann::json& value) {
  JsonFields f(value, "chain.limiter");
  LimiterConfig c;
  c.knee = f.number("knee", c.knee);
  if (!(c.knee >= 0.0 && c.knee < 1.0)) {
    throw ConfigError(f.path_of("knee") + ": must be within [0, 1), got " + show(c.knee));
  }
  // The limiter's trip is the last guard of the transducer: a level above full scale (which the limited drive
  // never reaches) or a long hold would switch it off.
  c.pinned_level = f.number("pinned_level", c.pinned_level);
  if (!(c.pinned_level > 0.0 && c.pinned_level <= 1.0)) {
    throw ConfigError(f.path_of("pinned_level") + ": must be within (0, 1] (full scale), got " + show(c.pinned_level));
  }
  c.max_pinned_ms = f.number("max_pinned_ms", c.max_pinned_ms);
  models::require_within(c.max_pinned_ms, 0.0, kLongestPinnedMs, f.path_of("max_pinned_ms"));
  f.finish();
  return c;
}

nlohmann::json slot_to_json(const SlotConfig& s, bool feedback) {
  nlohmann::json j = {{"model", s.path.empty() ? s.model : nlohmann::json(s.path)}, {"bypass", s.bypass}};
  if (feedback) j["source"] = source_name(s.source);
  return j;
}

nlohmann::json band_pass_identity(const BandPassDesign& d) {
  return {{"kind", "band_pass"}, {"low_hz", d.low.value}, {"high_hz", d.high.value}, {"order", d.order}};
}

std::unique_ptr<Stage> band_pass_stage(const BandPassDesign& design) {
  auto stage = std::make_unique<BandPassStage>(design);
  stage->set_id(model_id(band_pass_identity(design)));
  return stage;
}

std::unique_ptr<Stage> slot_stage(const SlotConfig& slot, bool feedback) {
  std::unique_ptr<Stage> stage = make_stage(slot.model, slot_role(feedback), slot.source);
  stage->set_id(model_id(slot.model));
  return stage;
}

// The differences of one optional slot, appended to `out`.
void slot_differences(const std::optional<SlotConfig>& a, const std::optional<SlotConfig>& b, const std::string& name,
                      std::vector<ConfigDifference>& out) {
  if (a.has_value() != b.has_value()) {
    out.push_back({name, ChangeClass::rebuild_with_crossfade});
    return;
  }
  if (!a) return;
  if (a->model != b->model) out.push_back({name + ".model", ChangeClass::rebuild_with_crossfade});
  if (a->source != b->source) out.push_back({name + ".source", ChangeClass::rebuild_with_crossfade});
  if (a->bypass != b->bypass) out.push_back({name + ".bypass", ChangeClass::in_place});
}

bool slot_needs_stage(const std::optional<SlotConfig>& a, const std::optional<SlotConfig>& b) {
  if (a.has_value() != b.has_value()) return true;
  return a && (a->model != b->model || a->source != b->source);
}

std::string keys_of(const ConfigChange& change, ChangeClass kind) {
  std::string keys;
  for (const ConfigDifference& d : change.differences) {
    if (d.kind != kind) continue;
    keys += (keys.empty() ? "" : ", ") + d.key;
  }
  return keys;
}

}  // namespace

bool operator==(const ChainConfig& a, const ChainConfig& b) {
  return a.fs == b.fs && a.block == b.block && same_design(a.band_pass.design, b.band_pass.design) &&
         a.band_pass.bypass == b.band_pass.bypass && same_slot(a.feedforward, b.feedforward) &&
         same_slot(a.feedback, b.feedback) && a.crossfade_ms == b.crossfade_ms && a.history == b.history &&
         a.limiter.knee == b.limiter.knee && a.limiter.pinned_level == b.limiter.pinned_level &&
         a.limiter.max_pinned_ms == b.limiter.max_pinned_ms;
}

ChainConfig chain_config_from_json(const nlohmann::json& json, const std::filesystem::path& folder) {
  JsonFields top(json, "chain");
  const std::string format = top.string("format", "");
  if (format != kChainFormat) {
    throw ConfigError(top.path_of("format") + ": expected \"" + kChainFormat + "\", got " +
                      (json.contains("format") ? json["format"].dump() : std::string("nothing")));
  }
  ChainConfig c;
  c.fs = top.number("fs");
  models::require_within(c.fs, 1.0, 1e6, top.path_of("fs"));
  c.block = static_cast<int>(top.integer("block", c.block, 1, 8192));
  // An absent band_pass stands for its defaults, which must suit fs as well (a 1200 Hz corner at fs = 300 Hz
  // is no filter: the chain was accepted, then its own JSON form was refused).
  const nlohmann::json* band_pass = top.member("band_pass");
  c.band_pass = parse_band_pass(band_pass != nullptr ? *band_pass : nlohmann::json::object(), c.fs);
  if (const nlohmann::json* v = top.member("feedforward")) c.feedforward = parse_slot(*v, "feedforward", c.fs, folder, false);
  if (const nlohmann::json* v = top.member("feedback")) c.feedback = parse_slot(*v, "feedback", c.fs, folder, true);
  c.crossfade_ms = top.number("crossfade_ms", c.crossfade_ms);
  models::require_within(c.crossfade_ms, 0.0, 10000.0, top.path_of("crossfade_ms"));
  c.history = static_cast<int>(top.integer("history", c.history, 0, 1 << 20));
  if (const nlohmann::json* v = top.member("limiter")) c.limiter = parse_limiter(*v);
  top.finish();
  return c;
}

ChainConfig load_chain_file(const std::filesystem::path& path) {
  const nlohmann::json json = models::read_json_file(path);
  try {
    return chain_config_from_json(json, path.parent_path());
  } catch (const ConfigError& e) {
    throw ConfigError(path.string() + ": " + e.what());
  }
}

nlohmann::json chain_config_to_json(const ChainConfig& c) {
  nlohmann::json j = {
      {"format", kChainFormat},
      {"fs", c.fs},
      {"block", c.block},
      {"band_pass",
       {{"low_hz", c.band_pass.design.low.value},
        {"high_hz", c.band_pass.design.high.value},
        {"order", c.band_pass.design.order},
        {"bypass", c.band_pass.bypass}}},
  };
  if (c.feedforward) j["feedforward"] = slot_to_json(*c.feedforward, false);
  if (c.feedback) j["feedback"] = slot_to_json(*c.feedback, true);
  j["crossfade_ms"] = c.crossfade_ms;
  j["history"] = c.history;
  j["limiter"] = {{"knee", c.limiter.knee},
                  {"pinned_level", c.limiter.pinned_level},
                  {"max_pinned_ms", c.limiter.max_pinned_ms}};
  return j;
}

ChainOptions chain_options(const ChainConfig& c) {
  ChainOptions o;
  o.spec.fs = c.fs;
  o.spec.max_block = c.block;
  o.band_pass = c.band_pass.design;
  o.slots.crossfade = Samples{to_samples(c.crossfade_ms, c.fs)};
  o.slots.history = Samples{c.history};
  o.limiter.knee = c.limiter.knee;
  o.limiter.pinned_level = c.limiter.pinned_level;
  o.limiter.max_pinned = Samples{to_samples(c.limiter.max_pinned_ms, c.fs)};
  return o;
}

std::uint64_t model_id(const nlohmann::json& model) {
  // FNV-1a, 64 bits
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char byte : model.dump()) {
    h ^= byte;
    h *= 1099511628211ull;
  }
  h &= (std::uint64_t{1} << 48) - 1;
  return h == 0 ? 1 : h;
}

std::unique_ptr<Chain> make_chain(const ChainConfig& config) {
  auto chain = std::make_unique<Chain>(chain_options(config));
  chain->band_pass().set_initial(band_pass_stage(config.band_pass.design));
  chain->band_pass().set_initial_bypass(config.band_pass.bypass);
  const auto fill = [](ModelSlot& slot, const std::optional<SlotConfig>& c, const char* name) {
    if (!c) return;
    try {
      slot.set_initial(slot_stage(*c, std::string(name) == "feedback"));
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string(name) + ": " + e.what());
    }
    slot.set_initial_bypass(c->bypass);
  };
  fill(chain->feedforward(), config.feedforward, "feedforward");
  fill(chain->feedback(), config.feedback, "feedback");
  return chain;
}

const char* change_class_name(ChangeClass kind) {
  switch (kind) {
    case ChangeClass::none:
      return "none";
    case ChangeClass::in_place:
      return "in place";
    case ChangeClass::rebuild_with_crossfade:
      return "rebuild with crossfade";
    case ChangeClass::restart:
      return "restart";
  }
  return "unknown";
}

ConfigChange classify_change(const ChainConfig& a, const ChainConfig& b) {
  ConfigChange change;
  std::vector<ConfigDifference>& d = change.differences;
  // The rate and the block length size every buffer; the history sizes the slots' buffers.
  if (a.fs != b.fs) d.push_back({"fs", ChangeClass::restart});
  if (a.block != b.block) d.push_back({"block", ChangeClass::restart});
  const BandPassDesign& p = a.band_pass.design;
  const BandPassDesign& q = b.band_pass.design;
  if (p.low.value != q.low.value) d.push_back({"band_pass.low_hz", ChangeClass::rebuild_with_crossfade});
  if (p.high.value != q.high.value) d.push_back({"band_pass.high_hz", ChangeClass::rebuild_with_crossfade});
  if (p.order != q.order) d.push_back({"band_pass.order", ChangeClass::rebuild_with_crossfade});
  if (a.band_pass.bypass != b.band_pass.bypass) d.push_back({"band_pass.bypass", ChangeClass::in_place});
  slot_differences(a.feedforward, b.feedforward, "feedforward", d);
  slot_differences(a.feedback, b.feedback, "feedback", d);
  if (a.crossfade_ms != b.crossfade_ms) d.push_back({"crossfade_ms", ChangeClass::in_place});
  if (a.history != b.history) d.push_back({"history", ChangeClass::restart});
  if (a.limiter.knee != b.limiter.knee) d.push_back({"limiter.knee", ChangeClass::in_place});
  if (a.limiter.pinned_level != b.limiter.pinned_level) d.push_back({"limiter.pinned_level", ChangeClass::in_place});
  if (a.limiter.max_pinned_ms != b.limiter.max_pinned_ms) d.push_back({"limiter.max_pinned_ms", ChangeClass::in_place});
  for (const ConfigDifference& x : d) change.kind = std::max(change.kind, x.kind);
  return change;
}

ConfigChange apply_change(Chain& chain, const ChainConfig& before, const ChainConfig& after) {
  const ProcessSpec& spec = chain.options().spec;
  if (spec.fs != before.fs || spec.max_block != before.block) {
    throw std::invalid_argument("apply change: the chain runs at fs = " + show(spec.fs) + " Hz, block " +
                                std::to_string(spec.max_block) + ", not at the configuration it is said to run (fs = " +
                                show(before.fs) + " Hz, block " + std::to_string(before.block) + ")");
  }
  const ConfigChange change = classify_change(before, after);
  if (change.kind == ChangeClass::restart) {
    throw std::invalid_argument("apply change: " + keys_of(change, ChangeClass::restart) +
                                " changed: the chain must be restarted (rebuilt with make_chain)");
  }
  const ChainOptions next = chain_options(after);
  if (!(before.limiter == after.limiter)) SafetyLimiter::validate(next.limiter);  // before anything changes

  // Build and prepare every new stage first, so that a failure changes nothing.
  std::unique_ptr<Stage> band_pass, feedforward, feedback;
  const auto build = [&spec](const std::optional<SlotConfig>& c, const char* name) -> std::unique_ptr<Stage> {
    try {
      std::unique_ptr<Stage> stage = c ? slot_stage(*c, std::string(name) == "feedback") : std::make_unique<PassThroughStage>();
      stage->prepare(spec);
      return stage;
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string("apply change: ") + name + ": " + e.what());
    }
  };
  if (!same_design(before.band_pass.design, after.band_pass.design)) {
    band_pass = band_pass_stage(after.band_pass.design);
    try {
      band_pass->prepare(spec);
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string("apply change: band_pass: ") + e.what());
    }
  }
  if (slot_needs_stage(before.feedforward, after.feedforward)) feedforward = build(after.feedforward, "feedforward");
  if (slot_needs_stage(before.feedback, after.feedback)) feedback = build(after.feedback, "feedback");

  if (band_pass) chain.band_pass().install(std::move(band_pass));
  if (feedforward) chain.feedforward().install(std::move(feedforward));
  if (feedback) chain.feedback().install(std::move(feedback));
  chain.band_pass().set_bypassed(after.band_pass.bypass);
  chain.feedforward().set_bypassed(after.feedforward && after.feedforward->bypass);
  chain.feedback().set_bypassed(after.feedback && after.feedback->bypass);
  if (before.crossfade_ms != after.crossfade_ms) chain.set_crossfade(next.slots.crossfade);
  if (!(before.limiter == after.limiter) && !chain.set_limiter(next.limiter)) {
    throw std::invalid_argument("apply change: limiter: the previous limiter change has not been taken yet; try again");
  }
  return change;
}

}  // namespace panelbass::engine
