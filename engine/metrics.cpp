#include "engine/metrics.h"

#include <bit>
#include <cmath>

namespace panelbass::engine {

const char* fault_name(Fault fault) {
  switch (fault) {
    case Fault::none: return "none";
    case Fault::non_finite_input: return "non-finite input";
    case Fault::non_finite_output: return "non-finite output";
    case Fault::pinned: return "drive pinned at the rails";
    case Fault::sensor_lost: return "sensor lost (feedback runs on its plant model)";
  }
  return "unknown";
}

std::size_t Metrics::bin_of(std::uint64_t ns) noexcept {
  if (ns < 8) return static_cast<std::size_t>(ns);
  // octave = bit width (≥ 4); the two bits after the leading one pick a quarter of the octave
  const int octave = std::bit_width(ns);
  const std::uint64_t quarter = (ns >> (octave - 3)) & 3u;
  return 8 + static_cast<std::size_t>(octave - 4) * 4 + static_cast<std::size_t>(quarter);
}

double Metrics::bin_upper_ns(std::size_t bin) noexcept {
  if (bin < 8) return static_cast<double>(bin + 1);
  const int octave = static_cast<int>((bin - 8) / 4) + 4;
  const double quarter = static_cast<double>((bin - 8) % 4);
  return std::ldexp(5.0 + quarter, octave - 3);
}

void Metrics::record_block(std::uint64_t ns, std::size_t samples) noexcept {
  blocks_.fetch_add(1, std::memory_order_relaxed);
  samples_.fetch_add(samples, std::memory_order_relaxed);
  total_ns_.fetch_add(ns, std::memory_order_relaxed);
  if (ns > max_ns_.load(std::memory_order_relaxed)) max_ns_.store(ns, std::memory_order_relaxed);
  histogram_[bin_of(ns)].fetch_add(1, std::memory_order_relaxed);
}

void Metrics::record_fault(Fault fault) noexcept {
  faults_.fetch_add(1, std::memory_order_relaxed);
  last_fault_.store(fault, std::memory_order_relaxed);
}

void Metrics::set_active_id(std::size_t slot, std::uint64_t id) noexcept {
  if (slot < kSlotCount) active_ids_[slot].store(id, std::memory_order_relaxed);
}

MetricsSnapshot Metrics::snapshot() const {
  MetricsSnapshot s;
  s.blocks = blocks_.load(std::memory_order_relaxed);
  s.samples = samples_.load(std::memory_order_relaxed);
  s.faults = faults_.load(std::memory_order_relaxed);
  s.swaps = swaps_.load(std::memory_order_relaxed);
  s.xruns = xruns_.load(std::memory_order_relaxed);
  s.in_fault = in_fault_.load(std::memory_order_relaxed);
  s.peak_drive = peak_drive_.load(std::memory_order_relaxed);
  s.max_late_ns = static_cast<double>(max_late_ns_.load(std::memory_order_relaxed));
  s.last_fault = last_fault_.load(std::memory_order_relaxed);
  s.limited_samples = limited_samples_.load(std::memory_order_relaxed);
  s.over_range_samples = over_range_samples_.load(std::memory_order_relaxed);
  s.peak_demand = peak_demand_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < kSlotCount; ++i) s.active_ids[i] = active_ids_[i].load(std::memory_order_relaxed);
  const double total_ns = static_cast<double>(total_ns_.load(std::memory_order_relaxed));
  s.max_block_ns = static_cast<double>(max_ns_.load(std::memory_order_relaxed));
  if (s.blocks > 0) s.mean_block_ns = total_ns / static_cast<double>(s.blocks);
  if (s.samples > 0) s.ns_per_sample = total_ns / static_cast<double>(s.samples);
  if (s.samples > 0 && fs_ > 0.0) s.load = total_ns / (static_cast<double>(s.samples) / fs_ * 1e9);
  // A quantile: the first bin where the cumulative count reaches that share of the blocks counted.
  std::array<std::uint64_t, kBins> counts{};
  std::uint64_t counted = 0;
  for (std::size_t b = 0; b < kBins; ++b) counted += counts[b] = histogram_[b].load(std::memory_order_relaxed);
  const auto quantile = [&](double share) {
    const auto target = static_cast<std::uint64_t>(std::ceil(share * static_cast<double>(counted)));
    std::uint64_t cumulative = 0;
    for (std::size_t b = 0; b < kBins && counted > 0; ++b) {
      cumulative += counts[b];
      if (cumulative >= target) return std::fmin(bin_upper_ns(b), s.max_block_ns);
    }
    return 0.0;
  };
  s.p50_block_ns = quantile(0.50);
  s.p99_block_ns = quantile(0.99);
  return s;
}

}  // namespace panelbass::engine
