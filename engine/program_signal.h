#pragma once
// The program signals a live backend loops when no capture channel carries the program: a sine that loops
// without a click, seeded uniform noise, or silence — made off the audio thread at the rate it is played at.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace panelbass::engine {

/// What a program signal is.
enum class SignalKind { silence, noise, sine };

/// A program signal as named on a command line or in a request: "silence", "noise" or "sine:HZ".
struct SignalName {
  SignalKind kind = SignalKind::silence;  ///< which signal
  double frequency_hz = 0.0;              ///< a sine's frequency as written (not yet checked against a rate)
};

/// The signal `text` names ("silence", "noise", "sine:HZ" with HZ a number); nullopt for anything else.
std::optional<SignalName> parse_signal_name(const std::string& text);

/// A looped program's samples and the frequency its loop makes exact (0 for noise and silence).
struct LoopedSignal {
  std::vector<double> samples;  ///< one loop at the rate asked for (empty: silence)
  double frequency_hz = 0.0;    ///< a sine's frequency after rounding its loop to whole samples
};

/// The lowest sine a program loops, Hz: one period in at most ten seconds (a lower one is no tone, and its
/// loop would not fit in memory).
inline constexpr double kLowestSineHz = 0.1;

/// A sine of `frequency` Hz and peak `amplitude` at rate `fs` that loops without a click: the whole number of
/// periods (in about one second) whose length is closest to a whole number of samples, at the frequency that
/// makes it exact. Throws std::invalid_argument unless kLowestSineHz <= frequency < fs/2.
LoopedSignal looped_sine(double frequency, double amplitude, double fs);

/// Ten seconds of uniform white noise of peak `amplitude` at rate `fs`, seeded by `seed`.
LoopedSignal looped_noise(double amplitude, std::uint64_t seed, double fs);

}  // namespace panelbass::engine
