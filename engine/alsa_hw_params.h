#pragma once
// Hardware negotiation: the hardware and software parameters the ALSA backend opens a PCM with, and
// what the device offers when it refuses one (libasound's types: for the backend's own files only).

#include <alsa/asoundlib.h>

#include <cstddef>

#include "engine/alsa_backend.h"

namespace panelbass::engine {

/// Configures `pcm` for `channels` interleaved channels at the options' rate, period and period count;
/// picks the first format of kAlsaFormats it takes and reports it in `format`, the buffer it was granted
/// in `buffer_frames`. Returns 0 or a negative errno with `what` (a buffer of `what_size` characters)
/// saying what was refused. Both streams are left to start when the backend says so.
int configure_pcm(snd_pcm_t* pcm, const AlsaOptions& o, unsigned channels, snd_pcm_format_t& format,
                  snd_pcm_uframes_t& buffer_frames, char* what, std::size_t what_size);

}  // namespace panelbass::engine
