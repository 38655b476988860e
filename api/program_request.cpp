#include "api/program_request.h"

#include <cmath>
#include <string>

#include "api/engine_service.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

[[noreturn]] void bad(const std::string& key, const std::string& what) {
  throw EngineRequestError(400, "bad_request", "program." + key + ": " + what);
}

}  // namespace

ProgramRequest parse_program_request(const nlohmann::json& body, double fs, double safe_level) {
  if (!body.is_object()) {
    throw EngineRequestError(400, "bad_request",
                             "program: expected an object such as {\"signal\":\"sine:80\",\"amplitude\":0.2}");
  }
  for (const auto& [key, value] : body.items()) {
    if (key != "signal" && key != "amplitude" && key != "seed") bad(key, "unknown field (expected signal, amplitude, seed)");
  }
  ProgramRequest r;
  const auto signal = body.find("signal");
  if (signal == body.end() || !signal->is_string()) {
    bad("signal", "required: \"noise\", \"silence\" or \"sine:HZ\" (e.g. \"sine:80\")");
  }
  const std::string text = signal->get<std::string>();
  const std::optional<engine::SignalName> name = engine::parse_signal_name(text);
  if (!name) bad("signal", "expected \"noise\", \"silence\" or \"sine:HZ\" (e.g. \"sine:80\"), got \"" + text + "\"");
  r.signal = *name;
  if (r.signal.kind == engine::SignalKind::sine &&
      !(r.signal.frequency_hz >= engine::kLowestSineHz && r.signal.frequency_hz < fs / 2.0)) {
    bad("signal", "the sine's frequency must be within [" + models::number_text(engine::kLowestSineHz) + ", " +
                      models::number_text(fs / 2.0) + ") Hz (up to half the engine's rate), got " +
                      models::number_text(r.signal.frequency_hz));
  }
  r.amplitude = 0.2;
  if (const auto a = body.find("amplitude"); a != body.end()) {
    if (!a->is_number()) bad("amplitude", "expected a number within [0, 1]");
    r.amplitude = a->get<double>();
    if (!std::isfinite(r.amplitude) || r.amplitude < 0.0 || r.amplitude > 1.0) {
      bad("amplitude", "must be finite and within [0, 1], got " + models::number_text(r.amplitude));
    }
  }
  if (r.signal.kind == engine::SignalKind::silence) r.amplitude = 0.0;
  if (r.amplitude > safe_level) {
    bad("amplitude", models::number_text(r.amplitude) + " is above the sound card's safe level " +
                         models::number_text(safe_level) + " (serve --safe-level)");
  }
  if (const auto s = body.find("seed"); s != body.end()) {
    if (r.signal.kind != engine::SignalKind::noise) bad("seed", "only \"noise\" takes a seed");
    if (!s->is_number_unsigned()) bad("seed", "expected a whole number >= 0");
    r.seed = s->get<std::uint64_t>();
  }
  return r;
}

engine::LoopedSignal program_samples(const ProgramRequest& request, double rate) {
  switch (request.signal.kind) {
    case engine::SignalKind::noise:
      return engine::looped_noise(request.amplitude, request.seed, rate);
    case engine::SignalKind::sine:
      return engine::looped_sine(request.signal.frequency_hz, request.amplitude, rate);
    case engine::SignalKind::silence:
      break;
  }
  return {};
}

nlohmann::json program_json(const ProgramRequest& request, const engine::LoopedSignal& played) {
  switch (request.signal.kind) {
    case engine::SignalKind::noise:
      return {{"signal", "noise"}, {"amplitude", request.amplitude}, {"seed", request.seed}};
    case engine::SignalKind::sine:
      return {{"signal", "sine:" + models::number_text(request.signal.frequency_hz, 12)},
              {"amplitude", request.amplitude},
              {"frequency_hz", played.frequency_hz}};
    case engine::SignalKind::silence:
      break;
  }
  return {{"signal", "silence"}, {"amplitude", 0.0}};
}

}  // namespace panelbass::api
