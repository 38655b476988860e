#include "engine/chain.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::engine {
namespace {

// Inputs beyond this magnitude could drive the band-pass's state towards overflow; block_run() leaves
// them (and everything after them) to the per-sample path, which restarts an overflowed band-pass at once.
constexpr double kLargestBlockInput = 1e100;

}  // namespace

Chain::Chain(const ChainOptions& options)
    : options_(options), limiter_(options.limiter) {
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

void Chain::process_block(std::span<const double> program, std::span<double> drive) noexcept {
  const ScopedFlushDenormals no_denormals;  // decaying tails stay out of slow subnormal arithmetic
  const auto started = std::chrono::steady_clock::now();
  begin_block();
  std::size_t k = 0;
  while (k < program.size() && block_runs()) {
    const std::size_t n = std::min(program.size() - k, static_cast<std::size_t>(options_.spec.max_block));
    const std::size_t done = block_run(program.subspan(k, n), drive.subspan(k, n));
    k += done;
    if (done < n) break;
  }
  // What the block runs could not take (a swap or fade under way, a fault, a non-finite or huge input):
  // sample by sample, the plant's output read as 0.
  for (; k < program.size(); ++k) {
    drive[k] = process_sample(program[k]);
    observe(0.0);
  }
  end_block(drive, started);
}

void Chain::end_block(std::span<const double> drive, std::chrono::steady_clock::time_point started) noexcept {
  double peak = 0.0;
  // (The limiter's drive is never NaN, so a plain max needs no fmax call per sample.)
  for (const double d : drive) peak = std::max(peak, std::abs(d));
  metrics_.record_peak_drive(peak);
  // A stage that limits its own output (the neural feedback's soft limit) hides from the limiter what it asked
  // for: its own count joins the chain's (its output stays below full scale, so no sample counts twice).
  for (auto& slot : slots_) {
    const StageDemand d = slot->take_demand();
    block_limiting_.over_range += d.over_range;
    block_limiting_.peak_demand = std::max(block_limiting_.peak_demand, d.peak);
  }
  metrics_.record_limiting(block_limiting_.limited, block_limiting_.over_range, block_limiting_.peak_demand);
  const auto elapsed = std::chrono::steady_clock::now() - started;
  metrics_.record_block(static_cast<std::uint64_t>(std::chrono::nanoseconds(elapsed).count()), drive.size());
}

bool Chain::block_runs() const noexcept {
  return !safe_bypass_ && !huge_input_seen_ && slots_[0]->steady() && slots_[1]->steady() && slots_[2]->steady();
}

std::size_t Chain::block_run(std::span<const double> program, std::span<double> drive) noexcept {
  // Up to the first input the per-sample path must see (non-finite: a fault; huge: a possible overflow).
  std::size_t n = 0;
  while (n < program.size() && std::abs(program[n]) <= kLargestBlockInput) ++n;
  if (n == 0) return 0;
  const std::span<const double> in = program.first(n);
  // Each stage over the whole run, then the limiter sample by sample. The band-pass cannot overflow on
  // these inputs (so it is never restarted inside the run), and it runs on in the safe bypass: all its n
  // samples count. The model slots' samples count up to the one that tripped the limiter, if any; that
  // one was processed but, the chain being in its bypass by then, not observed (as process_sample and
  // observe() per sample would have it). Their states beyond it do not matter: leaving the bypass resets them.
  // (Each slot's output stays valid until that slot runs its next block.)
  const std::span<const double> band = band_pass().process_block(in);
  const std::span<const double> fed = feedforward().process_block(band);
  const std::span<const double> v = feedback().process_block(fed);
  std::size_t k = 0;
  for (; k < n && !safe_bypass_; ++k) drive[k] = limit_sample(band[k], v[k]);
  const std::size_t modelled = k;
  for (; k < n; ++k) drive[k] = limit_sample(band[k], band[k]);
  band_pass().commit_block(in, n, n);
  const std::size_t observed = safe_bypass_ ? modelled - 1 : modelled;
  feedforward().commit_block(band, modelled, observed);
  feedback().commit_block(fed, modelled, observed);
  return n;
}

double Chain::process_sample(double x) noexcept {
  if (!std::isfinite(x)) {
    enter_safe_bypass(Fault::non_finite_input);
    x = 0.0;
  } else if (std::abs(x) > kLargestBlockInput) {
    huge_input_seen_ = true;
  }
  const double band = band_pass().process(x);
  const double v = safe_bypass_ ? band : feedback().process(feedforward().process(band));
  return limit_sample(band, v);
}

double Chain::limit_sample(double band, double v) noexcept {
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
