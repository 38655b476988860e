#pragma once
// The server's backend as a use case plays through it (usecases/transducer_port.h): a sound card's measurement
// (its round trip removed; the current and loopback channels when it captures them), or the virtual transducer.

#include <cstdint>

#include "api/jobs/job_environment.h"
#include "usecases/transducer_port.h"

namespace panelbass::api {

/// What a job's plays need of the backend beside the sensor.
enum class PlayedChannels { sensor, sensor_and_current };

/// Plays through `env`'s backend: on a sound card env.measure; on the virtual transducer env.excite, or — when
/// the current is needed — the transducer simulated on the drive (a new noise seed from `seed` for each play).
usecases::PlayFunction backend_play(const JobEnvironment& env, PlayedChannels channels, std::uint64_t seed);

}  // namespace panelbass::api
