#include "api/metrics_json.h"

namespace panelbass::api {

nlohmann::json metrics_to_json(const MetricsSnapshot& m) {
  return {{"blocks", m.blocks},
          {"samples", m.samples},
          {"xruns", m.xruns},
          {"faults", m.faults},
          {"in_fault", m.in_fault},
          {"peak_drive", m.peak_drive},
          {"last_fault", fault_name(m.last_fault)},
          {"swaps", m.swaps},
          {"mean_block_ns", m.mean_block_ns},
          {"p50_block_ns", m.p50_block_ns},
          {"p99_block_ns", m.p99_block_ns},
          {"max_block_ns", m.max_block_ns},
          {"max_late_ns", m.max_late_ns},
          {"ns_per_sample", m.ns_per_sample},
          {"load", m.load},
          {"active_ids",
           {{"band_pass", m.active_ids[0]}, {"feedforward", m.active_ids[1]}, {"feedback", m.active_ids[2]}}}};
}

}  // namespace panelbass::api
