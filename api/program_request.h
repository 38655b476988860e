#pragma once
// PUT /api/program's body (ROUTES.md "Program"): which signal the engine loops and how loud, checked
// completely against the engine's rate and the card's safe level before anything is built or played.

#include <cstdint>
#include <nlohmann/json.hpp>

#include "engine/program_signal.h"

namespace panelbass::api {

/// A program the engine is asked to loop.
struct ProgramRequest {
  engine::SignalName signal;  ///< silence, noise or sine:HZ
  double amplitude = 0.0;     ///< the signal's peak (0 for silence)
  std::uint64_t seed = 1;     ///< the noise's seed
};

/// The request in `body`: {"signal": "sine:80"|"noise"|"silence", "amplitude": 0.2, "seed": 1} (amplitude 0.2
/// unless given, seed for noise only, 1 unless given). Throws EngineRequestError 400 naming "program.<key>":
/// an unknown key, a signal not named so, a sine outside [kLowestSineHz, fs/2), an amplitude not finite or outside
/// [0, 1] or above `safe_level` (the card's, 1 on the virtual transducer), a bad seed.
ProgramRequest parse_program_request(const nlohmann::json& body, double fs, double safe_level);

/// The samples of `request` at `rate` (the rate it is played at: the chain's, or the card's).
engine::LoopedSignal program_samples(const ProgramRequest& request, double rate);

/// GET /api/program's description of `request` as played ({"signal","amplitude", "frequency_hz" for a sine
/// (the loop's exact frequency), "seed" for noise}).
nlohmann::json program_json(const ProgramRequest& request, const engine::LoopedSignal& played);

}  // namespace panelbass::api
