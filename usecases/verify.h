#pragma once
// `verify` / the verify job: controllers played through a transducer at equal output level (usecases/
// equal_output_thd.h) — the feedforward (an LQ feedforward behind the band-pass it was designed for, or a mirror
// filter) and optionally a neural feedback in model mode, in the chain the engine runs (its band-pass and limiter).
// The tune's verify step is the same comparison on the filter it fitted.

#include <nlohmann/json.hpp>
#include <string>

#include "engine/chain_file.h"
#include "usecases/equal_output_thd.h"
#include "usecases/progress.h"
#include "usecases/transducer_port.h"

namespace panelbass::usecases {

/// What `verify` is asked.
struct VerifyRequest {
  nlohmann::json feedforward_model;  ///< the feedforward's file object (a kind the feedforward slot takes)
  std::string feedforward_name;      ///< where it came from (a path, a stored id)
  nlohmann::json feedback_model;     ///< a neural feedback's file object, run in model mode (null: none)
  std::string feedback_name;         ///< where it came from (empty: none)
  /// The chain they run in (its band-pass and limiter; its slots are replaced); its fs is the transducer's rate.
  engine::ChainConfig chain;
  double safe_level = 1.0;  ///< the largest drive peak the transducer may be played, (0, 1]
  /// The probes: one program level (0.2, below the safe level) unless asked for more
  EqualOutputSettings settings{.levels = {0.2}};
};

/// Throws RequestError naming the field for a request out of range (the model files are read by verify).
void check(const VerifyRequest& request);

/// The request's fields as the API names them (the verify job's params; the chain and safe level are the server's).
nlohmann::json to_json(const VerifyRequest& request);

/// The chain verified: the request's with the feedforward in its slot — behind the band-pass an LQ feedforward was
/// designed for — and the feedback in model mode when given. RequestError naming "feedforward_model" or
/// "feedback_model" for a file of a kind its slot does not take.
engine::ChainConfig verified_chain(const VerifyRequest& request);

/// Plays the probes through `play`, the chain's drive then the transducer alone, and compares them at equal output.
EqualOutputReport verify(const VerifyRequest& request, const PlayFunction& play, Progress& progress);

}  // namespace panelbass::usecases
