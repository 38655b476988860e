#pragma once
// GET /metrics: the engine's, the jobs' and the HTTP server's counters in the Prometheus text format
// (version 0.0.4).

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "engine/alsa_backend.h"
#include "engine/metrics.h"

namespace panelbass::api {

/// What /metrics reports besides the engine's own metrics.
struct ServiceCounts {
  std::map<std::string, std::size_t> jobs_by_state;     ///< "queued", "running", … → number of jobs
  std::map<int, std::uint64_t> responses_by_status;    ///< HTTP status → responses sent
  std::size_t models_stored = 0;                        ///< models in the store
  std::optional<engine::AlsaStatus> device;             ///< the sound card's status (nullopt: virtual transducer)
};

/// The exposition text: one HELP and TYPE line per metric family, then its samples.
std::string prometheus_text(const engine::MetricsSnapshot& engine, const ServiceCounts& service);

}  // namespace panelbass::api
