#pragma once
// The ALSA backend's devices: the PCMs, the configuration they are opened from and their raw interleaved
// buffers (libasound's types: for the backend's own files only). Their lifecycle — open, restart in step,
// close, reopen with back-off — is in alsa_devices.cpp, always between periods, never inside one.

#include <alsa/asoundlib.h>

#include <vector>

#include "engine/alsa_backend.h"

namespace panelbass::engine {

/// The PCMs, the configuration they are opened from and their raw interleaved buffers.
struct AlsaBackend::Devices {
  snd_config_t* config = nullptr;  // parsed config_text (null: the system's configuration)
  snd_pcm_t* playback = nullptr;
  snd_pcm_t* capture = nullptr;
  snd_pcm_format_t playback_format = SND_PCM_FORMAT_FLOAT_LE;
  snd_pcm_format_t capture_format = SND_PCM_FORMAT_FLOAT_LE;
  snd_pcm_uframes_t buffer_frames = 0;  // playback buffer, as the device granted it
  std::vector<unsigned char> playback_raw, capture_raw;
  bool top_up = false;  // the first period after a (re)start brings the playback fill to its target

  ~Devices() {
    if (config != nullptr) snd_config_delete(config);
  }
};

}  // namespace panelbass::engine
