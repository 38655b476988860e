#include "engine/program_signal.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/excitation.h"
#include "dsp/period.h"

namespace panelbass::engine {

std::optional<SignalName> parse_signal_name(const std::string& text) {
  if (text == "silence") return SignalName{SignalKind::silence};
  if (text == "noise") return SignalName{SignalKind::noise};
  if (text.rfind("sine:", 0) != 0) return std::nullopt;
  const std::string number = text.substr(5);
  std::size_t used = 0;
  double f = 0.0;
  try {
    f = std::stod(number, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != number.size()) return std::nullopt;
  return SignalName{SignalKind::sine, f};
}

LoopedSignal looped_sine(double frequency, double amplitude, double fs) {
  if (!(frequency >= kLowestSineHz && frequency < fs / 2.0)) {
    throw std::invalid_argument("looped sine: the frequency must be within [" + std::to_string(kLowestSineHz) +
                                ", fs/2), got " + std::to_string(frequency));
  }
  const double period = fs / frequency;
  const long most = std::max(1L, static_cast<long>(std::floor(fs / period)));
  const long periods = dsp::closest_whole_periods(period, most, std::max(1L, most / 2));
  const auto length = static_cast<std::size_t>(std::max(1.0, std::round(static_cast<double>(periods) * period)));
  const double exact = static_cast<double>(periods) * fs / static_cast<double>(length);
  const Eigen::VectorXd x = dsp::sine(length, fs, exact, amplitude);
  return {{x.data(), x.data() + x.size()}, exact};
}

LoopedSignal looped_noise(double amplitude, std::uint64_t seed, double fs) {
  const auto n = static_cast<std::size_t>(std::lround(10.0 * fs));
  const Eigen::VectorXd x = dsp::uniform_noise(n, amplitude, seed);
  return {{x.data(), x.data() + x.size()}, 0.0};
}

}  // namespace panelbass::engine
