#include "engine/virtual_backend.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/sample_rate.h"
#include "engine/closed_loop.h"
#include "engine/realtime_thread.h"

namespace panelbass::engine {
namespace {

const VirtualBackendOptions& checked(const Chain& chain, const VirtualBackendOptions& options) {
  const ProcessSpec& spec = chain.options().spec;
  if (options.block.value < 1 || options.block.value > spec.max_block) {
    throw std::invalid_argument("virtual backend: block must be within [1, " + std::to_string(spec.max_block) +
                                "], got " + std::to_string(options.block.value));
  }
  if (!dsp::same_rate(options.plant.fs, spec.fs)) {
    throw std::invalid_argument("virtual backend: the plant runs at " + std::to_string(options.plant.fs) +
                                " Hz, the chain at " + std::to_string(spec.fs) + " Hz");
  }
  if (!(options.program_fade_s >= 0.0 && options.program_fade_s <= 10.0)) {
    throw std::invalid_argument("virtual backend: program_fade_s must be within [0, 10] s");
  }
  if (options.buffer_periods < 1) {
    throw std::invalid_argument("virtual backend: buffer_periods must be at least 1, got " +
                                std::to_string(options.buffer_periods));
  }
  return options;
}

}  // namespace

VirtualBackend::VirtualBackend(Chain& chain, VirtualBackendOptions options)
    : chain_(chain),
      options_(std::move(options)),
      plant_(checked(chain, options_).plant, options_.noise_seed),
      program_(std::move(options_.program), options_.loop,
               static_cast<std::size_t>(std::lround(options_.program_fade_s * chain.options().spec.fs))),
      program_block_(static_cast<std::size_t>(options_.block.value), 0.0),
      drive_(program_block_.size(), 0.0),
      measured_(program_block_.size(), 0.0) {}

VirtualBackend::~VirtualBackend() { stop(); }

void VirtualBackend::start() {
  if (thread_.joinable()) throw std::logic_error("virtual backend: already running");
  stop_.store(false, std::memory_order_relaxed);
  thread_ = std::thread([this] { run(); });
}

void VirtualBackend::stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

void VirtualBackend::wait() {
  if (thread_.joinable()) thread_.join();
}

void VirtualBackend::run() noexcept {
  if (options_.pacing == Pacing::real_time) {
    const RealtimeGrant grant = make_this_thread_realtime_and_locked(options_.realtime_priority);
    realtime_.store(grant.priority, std::memory_order_relaxed);
    memory_locked_.store(grant.memory_locked, std::memory_order_relaxed);
  }
  using clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double>(options_.block.value / chain_.options().spec.fs));
  // The buffer's slack: how late a block may be before the card it stands for would run dry.
  const auto slack = period * (options_.buffer_periods - 1);
  auto deadline = clock::now();
  while (!stop_.load(std::memory_order_relaxed)) {
    // Next block of program input: looped, or up to the end of a program played once.
    const std::size_t n = program_.fill(program_block_);
    if (n == 0 && !options_.loop) {
      finished_.store(true, std::memory_order_release);
      return;
    }
    const std::span<const double> in(program_block_.data(), n);
    const std::span<double> drive(drive_.data(), n), measured(measured_.data(), n);
    process_closed_loop(chain_, plant_, in, drive, measured);
    const std::uint64_t index = blocks_.fetch_add(1, std::memory_order_relaxed);
    if (options_.on_block) options_.on_block(BlockView{index, in, drive, measured});
    if (options_.pacing == Pacing::real_time) {
      deadline += period;
      const auto now = clock::now();
      if (now > deadline) {
        const auto late = std::chrono::duration_cast<std::chrono::nanoseconds>(now - deadline);
        chain_.metrics().record_lateness(static_cast<std::uint64_t>(late.count()));
      }
      if (now > deadline + slack) {
        chain_.metrics().record_xrun();
        deadline = now;  // start afresh rather than rushing to catch up
      } else if (now < deadline) {
        std::this_thread::sleep_until(deadline);
      }  // else: late, but within the buffer; the next block follows at once to catch up
    }
  }
}

}  // namespace panelbass::engine
