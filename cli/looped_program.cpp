#include "cli/looped_program.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/sample_rate.h"
#include "dsp/resample.h"
#include "dsp/wav_file.h"
#include "engine/program_signal.h"

namespace panelbass::cli {
namespace {

LoopedProgram sine_program(double frequency, double amplitude, double fs) {
  engine::LoopedSignal s = engine::looped_sine(frequency, amplitude, fs);
  const std::size_t length = s.samples.size();
  return {std::move(s.samples),
          {{"signal", "sine"}, {"frequency_hz", s.frequency_hz}, {"amplitude", amplitude}, {"loop_samples", length}}};
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
  const std::optional<engine::SignalName> name = engine::parse_signal_name(signal);
  if (!name) throw std::invalid_argument("--signal " + signal + ": expected noise, silence or sine:HZ, e.g. sine:80");
  switch (name->kind) {
    case engine::SignalKind::silence:
      return {{}, {{"signal", "silence"}}};
    case engine::SignalKind::noise: {
      // Ten seconds of uniform white noise, looped.
      engine::LoopedSignal s = engine::looped_noise(amplitude, seed, fs);
      const std::size_t n = s.samples.size();
      return {std::move(s.samples), {{"signal", "noise"}, {"amplitude", amplitude}, {"seed", seed}, {"loop_samples", n}}};
    }
    case engine::SignalKind::sine:
      if (!(name->frequency_hz >= engine::kLowestSineHz && name->frequency_hz < fs / 2.0)) {
        throw std::invalid_argument("--signal " + signal + ": the frequency must be within [" +
                                    std::to_string(engine::kLowestSineHz) + ", " + std::to_string(fs / 2.0) +
                                    ") Hz, up to half the chain's rate");
      }
      return sine_program(name->frequency_hz, amplitude, fs);
  }
  throw std::invalid_argument("--signal " + signal + ": expected noise, silence or sine:HZ");
}

}  // namespace panelbass::cli
