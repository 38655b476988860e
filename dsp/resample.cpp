#include "dsp/resample.h"

#include <samplerate.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace panelbass::dsp {

Eigen::VectorXd resample(const Eigen::VectorXd& signal, double from_hz, double to_hz) {
  if (!(std::isfinite(from_hz) && from_hz > 0.0 && std::isfinite(to_hz) && to_hz > 0.0)) {
    throw std::invalid_argument("resample: rates must be finite and > 0, got " + std::to_string(from_hz) + " Hz → " +
                                std::to_string(to_hz) + " Hz");
  }
  if (from_hz == to_hz) return signal;
  const double ratio = to_hz / from_hz;
  if (!src_is_valid_ratio(ratio)) {
    throw std::invalid_argument("resample: " + std::to_string(from_hz) + " Hz → " + std::to_string(to_hz) +
                                " Hz is a ratio outside [1/256, 256]");
  }
  if (!signal.allFinite()) throw std::invalid_argument("resample: the signal has a non-finite sample");
  const auto wanted = static_cast<Eigen::Index>(std::llround(static_cast<double>(signal.size()) * ratio));
  Eigen::VectorXd out = Eigen::VectorXd::Zero(wanted);
  if (signal.size() == 0 || wanted == 0) return out;

  std::vector<float> in(static_cast<std::size_t>(signal.size()));
  for (Eigen::Index k = 0; k < signal.size(); ++k) in[static_cast<std::size_t>(k)] = static_cast<float>(signal[k]);
  // Room for a few frames more than wanted: libsamplerate may round the length either way.
  std::vector<float> buffer(static_cast<std::size_t>(wanted) + 16);
  SRC_DATA data{};
  data.data_in = in.data();
  data.input_frames = static_cast<long>(in.size());
  data.data_out = buffer.data();
  data.output_frames = static_cast<long>(buffer.size());
  data.end_of_input = 1;
  data.src_ratio = ratio;
  if (const int error = src_simple(&data, SRC_SINC_BEST_QUALITY, 1); error != 0) {
    throw std::invalid_argument(std::string("resample: libsamplerate: ") + src_strerror(error));
  }
  const Eigen::Index produced = std::min<Eigen::Index>(wanted, data.output_frames_gen);
  for (Eigen::Index k = 0; k < produced; ++k) out[k] = buffer[static_cast<std::size_t>(k)];
  return out;
}

}  // namespace panelbass::dsp
