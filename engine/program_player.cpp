#include "engine/program_player.h"

#include <cmath>
#include <memory>
#include <numbers>
#include <utility>

namespace panelbass::engine {

ProgramPlayer::ProgramPlayer(std::vector<double> initial, bool loop, std::size_t fade_samples)
    : loop_(loop), fade_(fade_samples), active_(new Buffer(std::move(initial))) {}

ProgramPlayer::~ProgramPlayer() {
  collect_retired();
  delete pending_.exchange(nullptr);
  delete incoming_;
  delete active_;
}

void ProgramPlayer::install(std::vector<double> samples) {
  auto buffer = std::make_unique<Buffer>(std::move(samples));
  // Whatever was pending is ours again: the audio thread takes a buffer only by exchanging it out.
  std::unique_ptr<Buffer> never_taken(pending_.exchange(buffer.release(), std::memory_order_acq_rel));
  collect_retired();
}

std::size_t ProgramPlayer::collect_retired() { return delete_queued(retired_); }

void ProgramPlayer::take_pending() noexcept {
  // One hand-over at a time, and only with room to retire the buffer it replaces.
  if (phase_ != Phase::playing || !retired_.has_room()) return;
  if (pending_.load(std::memory_order_relaxed) == nullptr) return;
  // Fading before the hand-over shows: idle() reads pending_ first, so it never sees neither.
  fading_.store(true, std::memory_order_release);
  incoming_ = pending_.exchange(nullptr, std::memory_order_acq_rel);
  if (incoming_ == nullptr) {
    fading_.store(false, std::memory_order_release);
    return;
  }
  phase_ = Phase::fading_out;
  ramp_ = 0;
}

double ProgramPlayer::next_sample() noexcept {
  const Buffer& p = *active_;
  if (position_ >= p.size()) {
    if (!loop_ || p.empty()) return 0.0;
    position_ = 0;
  }
  return p[position_++];
}

std::size_t ProgramPlayer::fill(std::span<double> out) noexcept {
  take_pending();
  std::size_t played = out.size();
  for (std::size_t k = 0; k < out.size(); ++k) {
    if (!loop_ && phase_ == Phase::playing && position_ >= active_->size()) {
      // A program played once has ended (a replacement would have started a fade instead).
      played = k;
      for (; k < out.size(); ++k) out[k] = 0.0;
      break;
    }
    double x = next_sample();
    if (phase_ == Phase::fading_out) {
      // Raised cosine from 1 down to 0 at its last sample: g = (1 + cos(π·(r+1)/F)) / 2.
      const double r = static_cast<double>(ramp_ + 1) / static_cast<double>(fade_);
      x *= fade_ == 0 ? 0.0 : 0.5 * (1.0 + std::cos(std::numbers::pi * r));
      if (++ramp_ >= fade_) {
        retired_.push(std::exchange(active_, std::exchange(incoming_, nullptr)));  // room checked when taken
        position_ = 0;
        phase_ = fade_ == 0 ? Phase::playing : Phase::fading_in;
        ramp_ = 0;
        if (fade_ == 0) {
          x = next_sample();  // no fade: the new program's first sample at once
          fading_.store(false, std::memory_order_release);
        }
      }
    } else if (phase_ == Phase::fading_in) {
      // Raised cosine from 0 at its first sample up: g = (1 − cos(π·r/F)) / 2.
      const double r = static_cast<double>(ramp_) / static_cast<double>(fade_);
      x *= 0.5 * (1.0 - std::cos(std::numbers::pi * r));
      if (++ramp_ >= fade_) {
        phase_ = Phase::playing;
        fading_.store(false, std::memory_order_release);
      }
    }
    out[k] = x;
  }
  return played;
}

}  // namespace panelbass::engine
