#include "cli/looped_program.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/excitation.h"
#include "dsp/period.h"
#include "dsp/sample_rate.h"
#include "dsp/resample.h"
#include "dsp/wav_file.h"

namespace panelbass::cli {
namespace {
// A sine that loops without a click: the whole number of periods (in about one second) whose length is
// closest to a whole number of samples, at the frequency that makes it exact.
LoopedProgram looped_sine(double frequency, double amplitude, double fs) {
  const double period = fs / frequency;
  const long most = std::max(1L, static_cast<long>(std::floor(fs / period)));
  const long periods = dsp::closest_whole_periods(period, most, std::max(1L, most / 2));
  const auto length = static_cast<std::size_t>(std::max(1.0, std::round(static_cast<double>(periods) * period)));
  const double exact = static_cast<double>(periods) * fs / static_cast<double>(length);
  const Eigen::VectorXd x = dsp::sine(length, fs, exact, amplitude);
  return {{x.data(), x.data() + x.size()},
          {{"signal", "sine"}, {"frequency_hz", exact}, {"amplitude", amplitude}, {"loop_samples", length}}};
}

}  // namespace

LoopedProgram looped_program(const std::string& wav, const std::string& channel, const std::string& signal,
                             double amplitude, std::uint64_t seed, double fs) {
  if (!wav.empty()) {
    const dsp::Record r = dsp::read_wav(wav, {channel});
    Eigen::VectorXd x = r.columns.front();
    if (!dsp::same_rate(r.fs, fs)) x = dsp::resample(x, r.fs, fs);
    return {{x.data(), x.data() + x.size()},
            {{"file", wav}, {"channel", channel}, {"fs_file", r.fs}, {"loop_samples", x.size()}}};
  }
  if (signal == "silence") return {{}, {{"signal", "silence"}}};
  if (signal == "noise") {
    // Ten seconds of uniform white noise, looped.
    const auto n = static_cast<std::size_t>(std::lround(10.0 * fs));
    const Eigen::VectorXd x = dsp::uniform_noise(n, amplitude, seed);
    return {{x.data(), x.data() + x.size()},
            {{"signal", "noise"}, {"amplitude", amplitude}, {"seed", seed}, {"loop_samples", n}}};
  }
  if (signal.rfind("sine:", 0) == 0) {
    const std::string text = signal.substr(5);
    std::size_t used = 0;
    double f = 0.0;
    try {
      f = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size()) {
      throw std::invalid_argument("--signal " + signal + ": expected sine:HZ, e.g. sine:80");
    }
    if (!(f > 0.0 && f < fs / 2.0)) {
      throw std::invalid_argument("--signal " + signal + ": the frequency must be within (0, " +
                                  std::to_string(fs / 2.0) + ") Hz, half the chain's rate");
    }
    return looped_sine(f, amplitude, fs);
  }
  throw std::invalid_argument("--signal " + signal + ": expected noise, silence or sine:HZ");
}

}  // namespace panelbass::cli
