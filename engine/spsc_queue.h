#pragma once
// A bounded lock-free queue for one producer thread and one consumer thread: how the audio thread
// hands retired stages to a control thread without locking, allocating or freeing.

#include <array>
#include <atomic>
#include <cstddef>

namespace panelbass::engine {

/// A fixed ring of `Capacity` values; push() and pop() are wait-free (one thread each).
template <class T, std::size_t Capacity>
class SpscQueue {
 public:
  /// Producer: appends `value`; false (and nothing stored) when the queue is full.
  bool push(T value) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_.load(std::memory_order_acquire) == Capacity) return false;
    slots_[tail % Capacity] = value;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Consumer: takes the oldest value into `value`; false when the queue is empty.
  bool pop(T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return false;
    value = slots_[head % Capacity];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Producer: true when a push() would succeed.
  bool has_room() const noexcept {
    return tail_.load(std::memory_order_relaxed) - head_.load(std::memory_order_acquire) < Capacity;
  }

 private:
  std::array<T, Capacity> slots_{};
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
};

/// Consumer: deletes every object whose pointer is queued (the audio thread's retired ones); returns how many.
template <class T, std::size_t Capacity>
std::size_t delete_queued(SpscQueue<T*, Capacity>& queue) {
  std::size_t freed = 0;
  T* object = nullptr;
  while (queue.pop(object)) {
    delete object;
    ++freed;
  }
  return freed;
}

}  // namespace panelbass::engine
