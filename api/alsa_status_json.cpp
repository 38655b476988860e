#include "api/alsa_status_json.h"

#include <string>

namespace panelbass::api {

nlohmann::json alsa_status_to_json(const AlsaStatus& s, const RateBridgeLatency& latency) {
  return {{"state", alsa_state_name(s.state)},
          {"opens", s.opens},
          {"failed_opens", s.failed_opens},
          {"losses", s.losses},
          {"reopens", s.reopens()},
          {"xruns", s.xruns},
          {"periods", s.periods},
          {"realtime", s.realtime},
          {"memory_locked", s.memory_locked},
          {"last_error", std::string(s.last_error.data())},
          {"resampling_latency_samples", latency.total_samples},
          {"resampling_latency_ms", latency.total_ms}};
}

}  // namespace panelbass::api
