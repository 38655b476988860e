#include "engine/history_ring.h"

#include <algorithm>

namespace panelbass::engine {

HistoryRing::HistoryRing(std::size_t length) : input_(length), measured_(length) {}

void HistoryRing::push_input(double x) noexcept {
  const std::uint64_t k = count_++;
  if (!input_.empty()) {
    // Seqlock writer: announce that sample k's position (sample k − length's) is being rewritten before
    // rewriting it; a reader that copied the old values then sees the announcement.
    touched_.store(k + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    // Position k mod length, kept as a running index: no division per sample.
    newest_ = next_;
    next_ = next_ + 1 == input_.size() ? 0 : next_ + 1;
    input_[newest_].store(x, std::memory_order_relaxed);
    measured_[newest_].store(0.0, std::memory_order_relaxed);
  }
  final_.store(k, std::memory_order_release);
}

void HistoryRing::push_block(std::span<const double> in, std::size_t observed) noexcept {
  if (in.empty()) return;
  const std::uint64_t first = count_;
  count_ += in.size();
  if (!input_.empty()) {
    // Seqlock writer: every position the run rewrites is announced before any is rewritten (a reader may
    // drop a sample not yet rewritten; it never keeps one that was).
    touched_.store(count_, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    // In contiguous runs up to the ring's end: no wrap test per sample.
    const std::size_t size = input_.size();
    std::size_t pos = next_;
    for (std::size_t done = 0; done < in.size();) {
      const std::size_t run = std::min(in.size() - done, size - pos);
      for (std::size_t i = 0; i < run; ++i) {
        input_[pos + i].store(in[done + i], std::memory_order_relaxed);
        measured_[pos + i].store(0.0, std::memory_order_relaxed);
      }
      done += run;
      pos = pos + run == size ? 0 : pos + run;
    }
    next_ = pos;
    newest_ = pos == 0 ? size - 1 : pos - 1;
  }
  // As push_input() then set_measured(0) per observed sample: the last pushed sample is final only if observed.
  final_.store(first + std::min<std::uint64_t>(observed, in.size()), std::memory_order_release);
}

void HistoryRing::set_measured(double y) noexcept {
  if (count_ == 0) return;
  if (!measured_.empty()) measured_[newest_].store(y, std::memory_order_relaxed);
  final_.store(count_, std::memory_order_release);
}

void HistoryRing::snapshot(std::size_t n, Snapshot& out) const {
  const std::uint64_t size = input_.size();
  const std::uint64_t end = final_.load(std::memory_order_acquire);
  std::uint64_t begin = end - std::min<std::uint64_t>({n, size, end});
  out.input.resize(static_cast<std::size_t>(end - begin));
  out.measured.resize(out.input.size());
  for (std::uint64_t k = begin; k < end; ++k) {
    out.input[k - begin] = input_[k % size].load(std::memory_order_relaxed);
    out.measured[k - begin] = measured_[k % size].load(std::memory_order_relaxed);
  }
  // Seqlock reader: sample k was overwritten if the writer announced sample k + length or later.
  std::atomic_thread_fence(std::memory_order_acquire);
  const std::uint64_t touched = touched_.load(std::memory_order_relaxed);
  const std::uint64_t intact = touched > size ? touched - size : 0;
  if (intact > begin) {
    const auto drop = static_cast<std::ptrdiff_t>(std::min(intact, end) - begin);
    out.input.erase(out.input.begin(), out.input.begin() + drop);
    out.measured.erase(out.measured.begin(), out.measured.begin() + drop);
  }
  out.end = end;
}

}  // namespace panelbass::engine
