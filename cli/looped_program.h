#pragma once
// The program a live backend loops (`run`, `serve`): a WAV file, or a signal named on the command line.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace panelbass::cli {

/// A program the backend loops, and how it was made.
struct LoopedProgram {
  std::vector<double> samples;  ///< at the chain's rate
  nlohmann::json description;   ///< for the result
};

/// The program at rate `fs`: the WAV file `wav` (channel `channel`, resampled if needed) when given, else
/// `signal`: "noise" (ten seconds of uniform noise of peak `amplitude`, seeded), "silence" or "sine:HZ"
/// (a whole number of periods that loops without a click). Throws std::invalid_argument naming the option.
LoopedProgram looped_program(const std::string& wav, const std::string& channel, const std::string& signal,
                             double amplitude, std::uint64_t seed, double fs);

}  // namespace panelbass::cli
