#pragma once
// Timestamps of stored models and jobs.

#include <string>

namespace panelbass::api {

/// Now, UTC, ISO 8601 to the second ("2026-11-22T09:00:00Z").
std::string utc_now();

}  // namespace panelbass::api
