#pragma once
// The sample formats the ALSA backend speaks: which, and one sample read from or written to a raw
// interleaved buffer in each (libasound's types: included by the backend's own files only).

#include <alsa/asoundlib.h>

#include <cstddef>

namespace panelbass::engine {

/// The widest sample the backend speaks, bytes (FLOAT_LE, S32_LE: 4; S16_LE: 2).
inline constexpr std::size_t kMaxSampleBytes = 4;

/// The sample formats the backend speaks, best first.
inline constexpr snd_pcm_format_t kAlsaFormats[] = {SND_PCM_FORMAT_FLOAT_LE, SND_PCM_FORMAT_S32_LE,
                                                    SND_PCM_FORMAT_S16_LE};

/// The sample at `p` in `format` (one of kAlsaFormats) as a value in [−1, 1).
double read_sample(const unsigned char* p, snd_pcm_format_t format) noexcept;

/// Writes `x` to `p` in `format` (one of kAlsaFormats); the integer formats clamp it to [−1, 1].
void write_sample(unsigned char* p, snd_pcm_format_t format, double x) noexcept;

}  // namespace panelbass::engine
