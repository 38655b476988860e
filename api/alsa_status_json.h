#pragma once
// The ALSA backend's status as JSON (what `panelbass run --backend alsa` prints and GET /api/status
// returns under "engine.device").

#include <nlohmann/json.hpp>

#include "engine/alsa_backend.h"

namespace panelbass::api {

using engine::AlsaStatus;
using engine::RateBridgeLatency;

/// {"state","opens","failed_opens","losses","reopens","xruns","periods","realtime","memory_locked","last_error",
///  "resampling_latency_samples","resampling_latency_ms"}.
nlohmann::json alsa_status_to_json(const AlsaStatus& status, const RateBridgeLatency& latency);

}  // namespace panelbass::api
