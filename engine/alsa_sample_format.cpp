#include "engine/alsa_sample_format.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace panelbass::engine {

double read_sample(const unsigned char* p, snd_pcm_format_t format) noexcept {
  switch (format) {
    case SND_PCM_FORMAT_FLOAT_LE: {
      float x;
      std::memcpy(&x, p, sizeof x);
      return x;
    }
    case SND_PCM_FORMAT_S32_LE: {
      std::int32_t x;
      std::memcpy(&x, p, sizeof x);
      return x / 2147483648.0;
    }
    default: {
      std::int16_t x;
      std::memcpy(&x, p, sizeof x);
      return x / 32768.0;
    }
  }
}

void write_sample(unsigned char* p, snd_pcm_format_t format, double x) noexcept {
  switch (format) {
    case SND_PCM_FORMAT_FLOAT_LE: {
      const auto y = static_cast<float>(x);
      std::memcpy(p, &y, sizeof y);
      return;
    }
    case SND_PCM_FORMAT_S32_LE: {
      const auto y = static_cast<std::int32_t>(std::lrint(std::clamp(x, -1.0, 1.0) * 2147483647.0));
      std::memcpy(p, &y, sizeof y);
      return;
    }
    default: {
      const auto y = static_cast<std::int16_t>(std::lrint(std::clamp(x, -1.0, 1.0) * 32767.0));
      std::memcpy(p, &y, sizeof y);
      return;
    }
  }
}

}  // namespace panelbass::engine
