#include "engine/chain.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::engine {

Chain::Chain(const ChainOptions& options) : options_(options), limiter_(options.limiter) {
  if (!(options.spec.fs > 0.0) || options.spec.max_block < 1) {
    throw std::invalid_argument("chain: fs must be > 0 and max_block >= 1, got fs = " +
                                std::to_string(options.spec.fs) + ", max_block = " +
                                std::to_string(options.spec.max_block));
  }
  metrics_.set_rate(options.spec.fs);
  for (std::size_t i = 0; i < kSlotCount; ++i) {
    slots_[i] = std::make_unique<ModelSlot>(options.spec, options.slots, metrics_, i);
  }
  band_pass().set_initial(std::make_unique<BandPassStage>(options.band_pass));
}

std::size_t Chain::collect_retired() {
  std::size_t freed = 0;
  for (auto& s : slots_) freed += s->collect_retired();
  return freed;
}

bool Chain::set_limiter(const LimiterOptions& options) {
  SafetyLimiter::validate(options);
  if (limiter_request_.load(std::memory_order_acquire)) return false;  // the previous one is not taken yet
  pending_limiter_ = options;
  limiter_request_.store(true, std::memory_order_release);
  options_.limiter = options;
  return true;
}

void Chain::set_crossfade(Samples crossfade) {
  for (auto& s : slots_) s->set_crossfade(crossfade);
  options_.slots.crossfade = crossfade;
}

void Chain::begin_block() noexcept {
  block_limiting_ = {};
  if (limiter_request_.load(std::memory_order_acquire)) {
    limiter_.set_options(pending_limiter_);
    limiter_request_.store(false, std::memory_order_release);
  }
  if (clear_request_.exchange(false, std::memory_order_acq_rel) && safe_bypass_) {
    feedforward().reset();
    feedback().reset();
    limiter_.reset();
    safe_bypass_ = false;
    metrics_.set_in_fault(false);
  }
  // Faults a stage raised in the previous block (a lost sensor): recorded, nothing bypassed.
  for (auto& slot : slots_) {
    const Fault fault = slot->take_fault();
    if (fault != Fault::none) metrics_.record_fault(fault);
  }
  band_pass().begin_block();
  // In the safe bypass the model slots are not run; a pending install waits until the fault is cleared.
  if (!safe_bypass_) {
    feedforward().begin_block();
    feedback().begin_block();
  }
}

double Chain::process_sample(double x) noexcept {
  if (!std::isfinite(x)) {
    enter_safe_bypass(Fault::non_finite_input);
    x = 0.0;
  }
  const double band = band_pass().process(x);
  const double v = safe_bypass_ ? band : feedback().process(feedforward().process(band));
  const double drive = limiter_.process(v);
  // What the chain asked for against what the limiter let through (a non-finite v is a fault instead).
  const double demand = std::abs(v);
  if (std::isfinite(demand)) {
    block_limiting_.peak_demand = std::max(block_limiting_.peak_demand, demand);  // both finite: no fmax call
    if (demand > limiter_.options().knee) {
      ++block_limiting_.limited;
      if (demand >= 1.0) ++block_limiting_.over_range;
    }
  }
  switch (limiter_.take_trip()) {
    case Fault::none:
      break;
    case Fault::non_finite_output:
      // A band-pass driven into overflow by a huge input is restarted; the model slots are left alone.
      if (!std::isfinite(band)) band_pass().reset();
      enter_safe_bypass(Fault::non_finite_output);
      break;
    case Fault::pinned:
      // Only a controller can pin the drive; band-pass alone at full scale is the program's business.
      enter_safe_bypass(Fault::pinned);
      break;
    case Fault::non_finite_input:
    case Fault::sensor_lost:
      break;
  }
  return drive;
}

void Chain::observe(double measured) noexcept {
  band_pass().observe(measured);
  if (!safe_bypass_) {
    feedforward().observe(measured);
    feedback().observe(measured);
  }
}

void Chain::enter_safe_bypass(Fault fault) noexcept {
  if (safe_bypass_) return;
  safe_bypass_ = true;
  limiter_.reset();
  metrics_.set_in_fault(true);
  metrics_.record_fault(fault);
}

}  // namespace panelbass::engine
