#include "engine/model_slot.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace panelbass::engine {

ModelSlot::ModelSlot(const ProcessSpec& spec, const SlotOptions& options, Metrics& metrics, std::size_t index)
    : spec_(spec),
      options_(options),
      metrics_(metrics),
      index_(index),
      block_out_(static_cast<std::size_t>(std::max(1, spec.max_block)), 0.0),
      history_(static_cast<std::size_t>(std::max(0, options.history.value))) {
  if (options.crossfade.value < 0 || options.history.value < 0) {
    throw std::invalid_argument("model slot: crossfade and history must be >= 0 samples");
  }
  const auto h = static_cast<std::size_t>(options.history.value);
  peak_decay_ = h > 0 ? std::exp(-1.0 / static_cast<double>(h)) : 0.0;
  // decay^i for the longest block commit_block() is given (decay^0 = 1, then a product per power).
  decay_powers_.assign(block_out_.size() + 1, 1.0);
  for (std::size_t i = 1; i < decay_powers_.size(); ++i) decay_powers_[i] = decay_powers_[i - 1] * peak_decay_;
  crossfade_ = options.crossfade.value;
  crossfade_request_.store(crossfade_, std::memory_order_relaxed);
}

ModelSlot::~ModelSlot() {
  collect_retired();
  delete pending_.exchange(nullptr);
  delete warming_;
  delete incoming_;
  delete active_;
}

void ModelSlot::install(std::unique_ptr<Stage> stage) {
  if (!stage) throw std::invalid_argument("model slot: cannot install a null stage");
  stage->prepare(spec_);
  // The warm-up, here rather than on the audio thread: the stage runs from rest over the newest history
  // so its state is what it would be had it been running all along.
  HistoryRing::Snapshot recent;
  history_.snapshot(history_.length(), recent);
  auto entry = std::make_unique<Entry>();
  entry->last_output = stage->warm_up(recent.input, recent.measured);
  entry->warmed_through = recent.end;
  entry->stage = std::move(stage);
  // Whatever was pending is ours again: the audio thread takes a stage only by exchanging it out.
  std::unique_ptr<Entry> never_taken(pending_.exchange(entry.release(), std::memory_order_acq_rel));
  collect_retired();
}

void ModelSlot::set_initial(std::unique_ptr<Stage> stage) {
  if (!stage) throw std::invalid_argument("model slot: cannot set a null stage");
  stage->prepare(spec_);
  delete active_;
  active_ = new Entry{std::move(stage)};
  metrics_.set_active_id(index_, active_->stage->id());
}

std::size_t ModelSlot::collect_retired() { return delete_queued(retired_); }

bool ModelSlot::idle() const {
  return pending_.load(std::memory_order_acquire) == nullptr && !fading_.load(std::memory_order_acquire);
}

void ModelSlot::set_crossfade(Samples crossfade) {
  if (crossfade.value < 0) throw std::invalid_argument("model slot: crossfade must be >= 0 samples");
  crossfade_request_.store(crossfade.value, std::memory_order_relaxed);
}

void ModelSlot::set_initial_bypass(bool bypassed) {
  bypass_request_.store(bypassed, std::memory_order_relaxed);
  wet_ = wet_target_ = bypassed ? 0.0 : 1.0;
}

void ModelSlot::begin_block() noexcept {
  wet_target_ = bypass_request_.load(std::memory_order_relaxed) ? 0.0 : 1.0;
  block_peak_ = std::max(block_peak_, block_samples_);
  block_samples_ = 0;
  // A new crossfade length applies from a block boundary on, never in the middle of a fade.
  if (incoming_ == nullptr) crossfade_ = crossfade_request_.load(std::memory_order_relaxed);
  // One hand-over at a time, and only with room to retire the stage it replaces.
  if (incoming_ != nullptr || !retired_.has_room()) return;
  if (warming_ == nullptr) {
    warming_ = pending_.exchange(nullptr, std::memory_order_acq_rel);
    if (warming_ == nullptr) return;
    fading_.store(true, std::memory_order_release);
  }
  if (!catch_up(*warming_)) return;
  incoming_ = std::exchange(warming_, nullptr);
  last_new_ = incoming_->last_output;
  fade_gain_ = 0.0;
  metrics_.record_swap();
  if (crossfade_ == 0) {
    finish_swap();
    last_old_ = last_new_;
  }
}

bool ModelSlot::catch_up(Entry& entry) noexcept {
  const std::uint64_t now = history_.count();
  const std::uint64_t kept = std::min<std::uint64_t>(now, history_.length());
  if (now - entry.warmed_through > kept) {
    // What it missed is no longer kept: start it afresh from the oldest sample that is.
    entry.stage->reset();
    entry.last_output = 0.0;
    entry.warmed_through = now - kept;
  }
  // Behind by at most a block: caught up now, and the crossfade begins (at most two blocks' work for the
  // stage). Further behind: a block and a quarter per block without a crossfade, so the gap shrinks by a
  // quarter of a block per block and no block pays for a whole warm-up.
  const std::uint64_t block = std::max<std::uint64_t>(1, block_peak_);
  const std::uint64_t behind = now - entry.warmed_through;
  const bool take_over = behind <= block;
  const std::uint64_t steps = take_over ? behind : std::min(behind, block + std::max<std::uint64_t>(1, block / 4));
  for (std::uint64_t k = entry.warmed_through; k < entry.warmed_through + steps; ++k) {
    entry.last_output = entry.stage->process(history_.input(k));
    entry.stage->observe(history_.measured(k));
  }
  entry.warmed_through += steps;
  return take_over;
}

double ModelSlot::process(double x) noexcept {
  history_.push_input(x);
  ++block_samples_;
  const double old_out = active_ != nullptr ? active_->stage->process(x) : x;
  double y = old_out;
  double active_out = old_out;
  if (incoming_ != nullptr) {
    const double new_out = incoming_->stage->process(x);
    const double g = next_fade_gain(old_out, new_out);
    last_new_ = new_out;
    if (g >= 1.0) {
      y = active_out = new_out;
      finish_swap();
    } else {
      // y = (1 − g)·old + g·new
      fade_gain_ = g;
      y = old_out + g * (new_out - old_out);
    }
  }
  last_old_ = active_out;
  const double step = std::abs(y - last_mix_);
  step_peak_ = std::isfinite(step) ? std::max(step, step_peak_ * peak_decay_) : 0.0;
  last_mix_ = y;
  if (wet_ != wet_target_) {
    const double ramp = crossfade_ > 0 ? 1.0 / crossfade_ : 1.0;
    wet_ = wet_target_ > wet_ ? std::min(1.0, wet_ + ramp) : std::max(0.0, wet_ - ramp);
  }
  if (wet_ == 1.0) return y;
  if (wet_ == 0.0) return x;
  return x + wet_ * (y - x);
}

void ModelSlot::observe(double measured) noexcept {
  history_.set_measured(measured);
  if (active_ != nullptr) active_->stage->observe(measured);
  if (incoming_ != nullptr) incoming_->stage->observe(measured);
}

std::span<const double> ModelSlot::process_block(std::span<const double> in) noexcept {
  if (active_ == nullptr) {
    block_y_ = in;
  } else {
    // The stage ignores observe() (steady()), so the observe(0) per sample is left out.
    const std::span<double> y(block_out_.data(), in.size());
    active_->stage->process_block(in, y);
    block_y_ = y;
  }
  return wet_ == 0.0 ? in : block_y_;
}

void ModelSlot::commit_block(std::span<const double> in, std::size_t processed, std::size_t observed) noexcept {
  if (processed == 0) return;
  history_.push_block(in.first(processed), observed);
  block_samples_ += processed;
  // The step peak as process() keeps it sample by sample, peak ← max(step(k), peak·decay), in its closed form
  // max(peak·decay^n, max_k step(k)·decay^(n−1−k)): the same up to rounding, without a chain of dependent
  // multiplications and comparisons through the block (four running maxima). A non-finite step restarts the
  // peak at 0; for such a block the recursion itself runs.
  const double* decay = decay_powers_.data();
  double peak[4] = {0.0, 0.0, 0.0, 0.0};
  bool finite = true;
  double last = last_mix_;
  std::size_t k = 0;
  for (; k + 4 <= processed; k += 4) {
    for (std::size_t i = 0; i < 4; ++i) {
      const double step = std::abs(block_y_[k + i] - (i == 0 ? last : block_y_[k + i - 1]));
      finite &= step <= std::numeric_limits<double>::max();
      peak[i] = std::max(peak[i], step * decay[processed - 1 - k - i]);
    }
    last = block_y_[k + 3];
  }
  for (; k < processed; ++k) {
    const double step = std::abs(block_y_[k] - last);
    finite &= step <= std::numeric_limits<double>::max();
    peak[0] = std::max(peak[0], step * decay[processed - 1 - k]);
    last = block_y_[k];
  }
  if (finite) {
    step_peak_ = std::max({step_peak_ * decay[processed], peak[0], peak[1], peak[2], peak[3]});
  } else {
    double p = step_peak_, previous = last_mix_;
    for (std::size_t j = 0; j < processed; ++j) {
      const double step = std::abs(block_y_[j] - previous);
      p = std::isfinite(step) ? std::max(step, p * peak_decay_) : 0.0;
      previous = block_y_[j];
    }
    step_peak_ = p;
  }
  last_mix_ = last;
  last_old_ = last;
}

Fault ModelSlot::take_fault() noexcept {
  const Fault incoming = incoming_ != nullptr ? incoming_->stage->take_fault() : Fault::none;
  const Fault active = active_ != nullptr ? active_->stage->take_fault() : Fault::none;
  return active != Fault::none ? active : incoming;
}

StageDemand ModelSlot::take_demand() noexcept {
  if (incoming_ != nullptr) (void)incoming_->stage->take_demand();
  return active_ != nullptr ? active_->stage->take_demand() : StageDemand{};
}

void ModelSlot::reset() noexcept {
  if (active_ != nullptr) active_->stage->reset();
  if (incoming_ != nullptr) incoming_->stage->reset();
}

double ModelSlot::next_fade_gain(double old_out, double new_out) const noexcept {
  const double n = crossfade_;
  const double target = std::min(1.0, fade_gain_ + 1.0 / n);
  const double e = new_out - old_out;
  const double step_at_target = old_out + target * e - last_mix_;
  const double allowed =
      std::max({std::abs(old_out - last_old_), std::abs(new_out - last_new_), step_peak_});
  // (A non-finite value is the limiter's business: the fade just goes on.)
  if (std::abs(step_at_target) <= allowed || e == 0.0 || !std::isfinite(step_at_target + allowed)) return target;
  // The step old + g·e − last_mix is linear in g and within `allowed` at the held gain (a convex
  // combination of the two stages' steps): go as far as the bound on the side the target overshoots.
  const double held = old_out + fade_gain_ * e - last_mix_;
  const double g = fade_gain_ + (std::copysign(allowed, step_at_target) - held) / e;
  return std::clamp(g, std::min(1.0, fade_gain_ + 0.25 / n), target);
}

void ModelSlot::finish_swap() noexcept {
  // begin_block() made sure the queue has room, so the push cannot fail.
  if (active_ != nullptr) retired_.push(active_);
  active_ = std::exchange(incoming_, nullptr);
  metrics_.set_active_id(index_, active_->stage->id());
  fading_.store(false, std::memory_order_release);
}

}  // namespace panelbass::engine
