#include "api/metrics_json.h"

#include "api/model_store.h"

namespace panelbass::api {
namespace {

// A stage's id as the API names models ("m" + 12 hex digits); null for an empty slot.
nlohmann::json stage_id_json(std::uint64_t id) { return id == 0 ? nlohmann::json(nullptr) : nlohmann::json(model_store_id(id)); }

}  // namespace

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
          {"limited_samples", m.limited_samples},
          {"over_range_samples", m.over_range_samples},
          {"peak_demand", m.peak_demand},
          {"active_ids",
           {{"band_pass", stage_id_json(m.active_ids[0])},
            {"feedforward", stage_id_json(m.active_ids[1])},
            {"feedback", stage_id_json(m.active_ids[2])}}}};
}

}  // namespace panelbass::api
