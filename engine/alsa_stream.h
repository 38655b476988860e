#pragma once
// The ALSA backend's stream loop, period by period: read the capture period, run the chain (behind the
// rate bridge when the card runs at another rate), write the drive; xruns recovered and counted. Nothing
// here allocates or locks; it waits only on the devices, with the timeout below.

#include "engine/alsa_backend.h"

namespace panelbass::engine {

/// How a device call of the stream loop ended.
enum class AlsaIo { ok, restarted, lost };

/// How long the stream loop waits on a device before calling it lost, ms: the options' device_timeout,
/// or 8 device buffers (at least 200 ms) when that is 0.
int alsa_timeout_ms(const AlsaOptions& o) noexcept;

}  // namespace panelbass::engine
