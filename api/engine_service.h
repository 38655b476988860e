#pragma once
// The engine as the API sees it: a chain playing on the virtual transducer or on a sound card (ALSA), its
// settings in the API's form (models named by their store ids), changes validated completely before they
// are applied without interruption, and excitation records for identification jobs.

#include <Eigen/Core>
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "api/jobs/excitation_record.h"
#include "engine/alsa_backend.h"
#include "engine/chain.h"
#include "engine/chain_file.h"
#include "engine/virtual_backend.h"
#include "models/plant/plant_config.h"

namespace panelbass::api {

/// A request the engine refuses; `status` is the HTTP status it maps to (400 bad input, 409 conflict).
class EngineRequestError : public std::runtime_error {
 public:
  /// `status` 400 or 409, `code` "bad_request" or "conflict".
  EngineRequestError(int status, std::string code, const std::string& message)
      : std::runtime_error(message), status_(status), code_(std::move(code)) {}
  /// HTTP status.
  int status() const { return status_; }
  /// Error code of the API's error object.
  const std::string& code() const { return code_; }

 private:
  int status_;
  std::string code_;
};

/// Finds a stored model file object by id (nullopt if there is none).
using ModelLookup = std::function<std::optional<nlohmann::json>(const std::string& id)>;

/// What the engine runs when the service starts.
struct EngineServiceOptions {
  models::PlantConfig plant;                ///< the virtual transducer (its fs is the chain's)
  engine::ChainConfig chain;                ///< band-pass, limiter, crossfade … (slots empty)
  std::vector<double> program;              ///< looped program input at the chain's rate (empty: silence)
  /// What `program` (or the card's) is, as GET /api/program says it, e.g. {"signal":"sine:80","amplitude":0.2}
  /// (null: "silence" when empty, else "custom").
  nlohmann::json program_description;
  std::uint64_t seed = 1;                   ///< sensor noise of the playing plant; excitations use seed + 1, + 2, …
  engine::Pacing pacing = engine::Pacing::real_time;  ///< the audio thread's pacing
  int realtime_priority = 0;  ///< SCHED_FIFO priority of the virtual backend's audio thread (0: none)
  /// Play on a sound card instead (program from its options, at the device rate); the virtual transducer
  /// then only sets the chain's rate. nullopt: the virtual transducer.
  std::optional<engine::AlsaOptions> alsa;
  /// On a sound card: the largest drive peak a measurement may play (the exciter's safe level).
  double safe_level = 0.5;
  /// On a sound card: the program's fade out before a measurement and back in after it, seconds.
  double measurement_fade_s = 0.02;
  /// A new program (PUT /api/program): the old one faded out and the new one in, each this long, seconds.
  double program_fade_s = 0.025;
  /// The virtual transducer: called on the audio thread after each block (must not allocate, lock or wait).
  std::function<void(const engine::BlockView&)> on_block;
};

/// The chain slots a model can be activated in.
enum class ModelSlotName { feedforward, feedback };

/// "feedforward" or "feedback".
const char* slot_name(ModelSlotName slot);
/// The slot named `name`; throws EngineRequestError (400) otherwise.
ModelSlotName parse_slot_name(const std::string& name);
/// The slots that run a model of `kind`: feedforward an lq_feedforward, feedback a neural_feedback; none
/// for a plant model (linear, narx).
std::vector<ModelSlotName> slots_accepting(const std::string& kind);
/// The slot a model of `kind` goes to unless a client names one (nullopt: no slot runs it).
std::optional<ModelSlotName> default_slot(const std::string& kind);
/// The slot model `id` of `kind` goes to when a client names none; EngineRequestError (409) if none runs it.
ModelSlotName slot_for(const std::string& id, const std::string& kind);
/// Throws EngineRequestError (409) naming model `id`'s kind and what `slot` takes, unless `slot` runs `kind`.
void require_slot_accepts(ModelSlotName slot, const std::string& id, const std::string& kind);

/// What the safety limiter did over about the last second (the chain's counters sampled by housekeeping()).
struct LimiterActivity {
  double window_s = 0.0;             ///< the span the fractions cover (0 until two samples ~100 ms apart)
  double limited_fraction = 0.0;     ///< share of the window's samples the limiter compressed (above its knee)
  double over_range_fraction = 0.0;  ///< share whose drive asked for was at or beyond full scale
  bool needs_more_drive = false;     ///< over_range_fraction > 0: the program needs more drive than the chain allows
};

/// The running engine (thread-safe: every call may come from any HTTP or job thread).
class EngineService {
 public:
  /// Builds the chain and the backend (not yet playing); throws std::invalid_argument for bad options.
  explicit EngineService(EngineServiceOptions options);
  /// Stops the audio thread.
  ~EngineService();
  EngineService(const EngineService&) = delete;
  EngineService& operator=(const EngineService&) = delete;

  /// Starts the audio thread.
  void start();
  /// Stops the audio thread (idempotent).
  void stop();
  /// Frees retired stages and recovers from a fault: call every ~100 ms from a control thread. A chain
  /// in its safe bypass is cleared after a hold time (1 s, doubled up to 30 s while faults come back within
  /// 10 s of a recovery), so a passing fault costs a second of bypass and a persistent one is retried
  /// ever more rarely.
  void housekeeping();

  /// {"state","backend","plant","fs","block","uptime_s","realtime","recoveries","fault_hold_s"}; on a sound card
  /// also "device" (api/alsa_status_json.h: its state, losses, reopens, last error).
  nlohmann::json engine_status() const;
  /// The sound card's status (nullopt on the virtual transducer).
  std::optional<engine::AlsaStatus> device_status() const;
  /// The chain's metrics now.
  engine::MetricsSnapshot metrics() const;
  /// The limiter's activity over about the last second.
  LimiterActivity limiter_activity() const;
  /// The store id of the model active in `slot` (nullopt: the slot passes its input through).
  std::optional<std::string> active_model(ModelSlotName slot) const;
  /// The settings in the API's form (ROUTES.md "GET /api/config").
  nlohmann::json config() const;
  /// The chain the engine runs now (its models inline), for a job that runs it offline.
  engine::ChainConfig running_chain() const;

  /// Replaces the settings with `settings` (the API's form, all of it; fs, block and history may be left
  /// out). Validated completely first (unknown fields, types, ranges, models looked up in `lookup` and
  /// checked to run at the engine's rate) — EngineRequestError 400 naming "config.<key>", 409 for a change
  /// that needs a restart; then applied without interruption. Returns {"kind","keys"} of the change.
  nlohmann::json put_config(const nlohmann::json& settings, const ModelLookup& lookup);
  /// Applies a JSON merge patch (RFC 7386) to the settings, then as put_config.
  nlohmann::json patch_config(const nlohmann::json& patch, const ModelLookup& lookup);
  /// The program the engine loops (ROUTES.md "GET /api/program"): its signal, amplitude, rate, fade, and
  /// "settled" false while a new one is still being faded in.
  nlohmann::json program() const;
  /// Replaces the program with the one `request` names (ROUTES.md "PUT /api/program"), faded: built here,
  /// handed to the audio thread lock-free. EngineRequestError 400 naming "program.<key>", 409 when the card
  /// captures the program. Returns program().
  nlohmann::json put_program(const nlohmann::json& request);
  /// Puts stored model `id` (file object `model`) into `slot`, crossfaded. Returns {"kind","keys"}.
  nlohmann::json activate(ModelSlotName slot, const std::string& id, const nlohmann::json& model);

  /// Plays `drive` through the backend's transducer (a copy of the virtual transducer, so the chain keeps
  /// playing) and returns the measured response; throws std::invalid_argument for a drive outside [−1, 1]
  /// or non-finite, and EngineRequestError (409) on a sound card, which this service cannot measure through.
  Eigen::VectorXd excite(const Eigen::VectorXd& drive);
  /// On a sound card: plays a calibration sweep, then `drive`, through the playback PCM in place of the
  /// chain (program faded out and paused), captures the sensor (and current, loopback), finds the round
  /// trip from the loopback channel (else the sensor) and returns the response with it removed, at the
  /// chain's rate. Throws std::invalid_argument for a drive beyond the safe level, EngineRequestError (409)
  /// on the virtual transducer, std::runtime_error when the card interrupted it (an xrun, a lost device).
  MeasuredResponse measure(const Eigen::VectorXd& drive);
  /// The largest drive peak the backend may be excited with (1 on the virtual transducer).
  double safe_level() const { return alsa_ ? options_.safe_level : 1.0; }
  /// The simulated transducer.
  const models::PlantConfig& plant() const { return options_.plant; }
  /// The engine's rate, Hz.
  double fs() const { return options_.chain.fs; }

 private:
  nlohmann::json apply(const nlohmann::json& settings, const ModelLookup& lookup);
  nlohmann::json running_settings() const;
  nlohmann::json api_settings() const;
  engine::ProgramPlayer* program_player() const;

  // The limiter counters at one housekeeping tick.
  struct LimiterSample {
    std::chrono::steady_clock::time_point at;
    std::uint64_t samples = 0, limited = 0, over_range = 0;
  };

  EngineServiceOptions options_;
  mutable std::mutex mutex_;                 // serialises changes and guards the fields below
  engine::ChainConfig running_;              // what the chain runs now (models inline)
  std::array<std::optional<std::string>, 2> active_ids_;  // store ids in the feedforward and feedback slots
  nlohmann::json program_;                   // what the program player plays (GET /api/program)
  std::unique_ptr<engine::Chain> chain_;
  std::unique_ptr<engine::VirtualBackend> backend_;  // one of these two plays
  std::unique_ptr<engine::AlsaBackend> alsa_;
  bool playing_ = false;
  std::chrono::steady_clock::time_point started_{};
  std::uint64_t excitations_ = 0;
  // Fault recovery (housekeeping thread only, besides the counters read under mutex_).
  std::optional<std::chrono::steady_clock::time_point> fault_since_;
  std::chrono::steady_clock::time_point last_recovery_{};
  double hold_s_ = 1.0;
  std::uint64_t recoveries_ = 0;
  std::deque<LimiterSample> limiter_samples_;  // the last second's ticks, oldest first (under mutex_)
};

}  // namespace panelbass::api
