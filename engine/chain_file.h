#pragma once
// The chain file: what the engine runs, as one JSON object ("format": "panelbass.chain/1"), e.g.
//   {"format":"panelbass.chain/1","fs":3000,"block":64,
//    "band_pass":{"low_hz":20,"high_hz":1200,"order":2,"bypass":false},
//    "feedforward":{"model":"ff.json","bypass":false},
//    "feedback":{"model":"fb.json","source":"model","bypass":false},
//    "crossfade_ms":20,"history":512,"limiter":{"knee":0.8,"pinned_level":1.0,"max_pinned_ms":100}}
// Model paths are relative to the chain file's folder, or the model object is written inline. A change
// of configuration is classified before it is applied (CamillaDSP's habit): in place, rebuild with a
// crossfade, or restart.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/chain.h"

namespace panelbass::engine {

/// The format tag every chain file carries.
inline constexpr const char* kChainFormat = "panelbass.chain/1";

/// The band-pass stage of a chain file.
struct BandPassConfig {
  BandPassDesign design{};  ///< corners (low 0 = low-pass only) and order
  bool bypass = false;      ///< start (or switch) with the band-pass bypassed
};

/// A model slot of a chain file (feedforward or feedback).
struct SlotConfig {
  std::string path;  ///< the model file as written in the chain file (relative to its folder); empty if inline
  nlohmann::json model;  ///< the model file object (read from `path`, or the inline object)
  FeedbackSource source = FeedbackSource::model;  ///< where a feedback stage takes past outputs from
  bool bypass = false;  ///< start (or switch) with the slot bypassed
};

/// The longest max_pinned_ms a chain may set: one second of drive held at full scale, then the safe bypass.
inline constexpr double kLongestPinnedMs = 1000.0;

/// The safety limiter of a chain file, with its time in milliseconds.
struct LimiterConfig {
  double knee = 0.8;            ///< see LimiterOptions::knee
  double pinned_level = 1.0;    ///< see LimiterOptions::pinned_level; within (0, 1]
  double max_pinned_ms = 100.0; ///< longest time the drive may stay pinned at the rails; within [0, kLongestPinnedMs]
  /// Field by field.
  bool operator==(const LimiterConfig&) const = default;
};

/// A validated chain file.
struct ChainConfig {
  double fs = 3000.0;                     ///< rate the chain (and every model) runs at, Hz
  int block = 64;                         ///< block length the backends process (the chain's max_block)
  BandPassConfig band_pass{};             ///< the band-pass stage
  std::optional<SlotConfig> feedforward;  ///< the feedforward (linear controller) slot; empty = pass-through
  std::optional<SlotConfig> feedback;     ///< the feedback (neural controller) slot; empty = pass-through
  double crossfade_ms = 20.0;             ///< crossfade to a new stage and bypass ramp, ms
  int history = 512;                      ///< samples a new stage is warmed from
  LimiterConfig limiter{};                ///< the safety limiter
};

/// True when `a` and `b` describe the same chain (models compared by content, paths as written).
bool operator==(const ChainConfig& a, const ChainConfig& b);

/// Parses and validates a chain object; model paths are read relative to `folder`. Throws
/// models::ConfigError naming the key path ("chain.band_pass.high_hz: must be below fs/2 = 1500 Hz, got
/// 2000"): unknown keys, wrong types, values out of range, a corner outside (0, fs/2) (a low corner of 0
/// means low-pass only), a model that is unreadable, invalid, of a kind the engine cannot run, or at
/// another fs than the chain's.
ChainConfig chain_config_from_json(const nlohmann::json& json, const std::filesystem::path& folder);

/// Reads and validates a chain file (models relative to its folder); errors start with the file name.
ChainConfig load_chain_file(const std::filesystem::path& path);

/// The JSON form of `config`, every field written out (models as their path, or inline when they have none).
nlohmann::json chain_config_to_json(const ChainConfig& config);

/// The options a Chain of `config` is built with (times converted to samples at config.fs).
ChainOptions chain_options(const ChainConfig& config);

/// The id shown in the metrics for a model file object: the 64-bit FNV-1a hash of its compact JSON text,
/// kept to its low 48 bits so that it is exact in any JSON reader. Never 0 (0 means "no stage").
std::uint64_t model_id(const nlohmann::json& model);

/// A chain built from `config`: band-pass, the slots' stages from make_stage(), bypass flags set.
/// Call only while no audio runs; throws (naming the slot) if a stage cannot be built or prepared.
std::unique_ptr<Chain> make_chain(const ChainConfig& config);

/// How a change of chain configuration can be applied to a running chain.
enum class ChangeClass {
  none,                    ///< nothing changed
  in_place,                ///< bypass flags, crossfade length, limiter settings
  rebuild_with_crossfade,  ///< band-pass design, a slot's model or feedback source: new stages crossfaded in
  restart,                 ///< fs, block length, history length: a new chain (audio stops)
};

/// A short name of `kind` ("none", "in place", "rebuild with crossfade", "restart").
const char* change_class_name(ChangeClass kind);

/// One key whose value differs, and the class of its change.
struct ConfigDifference {
  std::string key;   ///< key path in the chain file ("band_pass.low_hz", "feedforward.model", …)
  ChangeClass kind;  ///< what changing it takes
};

/// The classified difference between two chain configurations.
struct ConfigChange {
  ChangeClass kind = ChangeClass::none;        ///< the most demanding class among the differences
  std::vector<ConfigDifference> differences;  ///< every key that differs, in chain-file order
};

/// Classifies the change from `before` to `after` without touching anything.
ConfigChange classify_change(const ChainConfig& before, const ChainConfig& after);

/// Control thread: applies the change from `before` (what `chain` runs now) to `after` while audio runs:
/// bypass flags through the slots, band-pass and model changes as new stages installed (warmed and
/// crossfaded by the slots). Every new stage is built and prepared before anything is touched, so a
/// change that fails leaves the chain as it was. Throws std::invalid_argument for a restart-class change
/// (naming the keys), for a chain that does not run at `before`'s fs and block length, and for invalid limiter settings;
/// returns the change applied. Crossfade and limiter changes take effect at the next block boundary.
ConfigChange apply_change(Chain& chain, const ChainConfig& before, const ChainConfig& after);

}  // namespace panelbass::engine
