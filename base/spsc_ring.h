// A lock-free single-producer single-consumer ring of trivially copyable
// records: the real-time cycle pushes, the logger thread pops. Push never
// blocks or allocates; when the ring is full the record is dropped and
// counted (the logger fell more than `capacity` cycles behind).
#ifndef KCRIG_BASE_SPSC_RING_H_
#define KCRIG_BASE_SPSC_RING_H_

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace kcrig {

template <typename Record>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<Record>);

 public:
  // `capacity` is rounded up to a power of two.
  explicit SpscRing(std::size_t capacity) {
    std::size_t size = 1;
    while (size < capacity) size <<= 1;
    slots_.resize(size);
    mask_ = size - 1;
  }

  // Producer only.
  bool Push(const Record& record) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) > mask_) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & mask_] = record;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Producer only: whether a Push now would drop.
  bool full() const {
    return head_.load(std::memory_order_relaxed) -
               tail_.load(std::memory_order_acquire) >
           mask_;
  }

  // Consumer only.
  bool Pop(Record* record) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    *record = slots_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  std::size_t capacity() const { return mask_ + 1; }
  std::uint64_t dropped() const {
    return dropped_.load(std::memory_order_relaxed);
  }

 private:
  std::vector<Record> slots_;
  std::size_t mask_ = 0;
  // Separate cache lines: the producer writes head_, the consumer tail_.
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace kcrig

#endif  // KCRIG_BASE_SPSC_RING_H_
