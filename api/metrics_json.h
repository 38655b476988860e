#pragma once
// The engine's metrics as JSON (what `panelbass run` prints and GET /api/status returns).

#include <nlohmann/json.hpp>

#include "engine/metrics.h"

namespace panelbass::api {

using engine::MetricsSnapshot;

/// {"blocks","samples","xruns","faults","in_fault","last_fault","swaps","mean_block_ns","p99_block_ns",
///  "max_block_ns","max_late_ns","ns_per_sample","load","limited_samples","over_range_samples","peak_demand",
///  "active_ids":{"band_pass","feedforward","feedback"}}; each active id as the API writes a model id
///  ("m" + 12 hex digits of the stage's model hash, null for an empty slot).
nlohmann::json metrics_to_json(const MetricsSnapshot& m);

}  // namespace panelbass::api
