#pragma once
// A fixed-capacity ring: pushing onto a full ring overwrites the oldest entry.
// The storage under a camera's pre-trigger buffer (burst_recorder.hpp); kept
// generic so other streams (e.g. a regulator's pressure log) can reuse it.
// Not thread-safe: the owner serialises access.
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

namespace collide::hw {

template <class T>
class RingBuffer {
 public:
  /// capacity >= 1 entries.
  explicit RingBuffer(std::size_t capacity) : slots_(capacity == 0 ? 1 : capacity) {}

  std::size_t capacity() const { return slots_.size(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == slots_.size(); }

  /// Appends `value` as the newest entry; returns the entry it overwrote, if
  /// the ring was full.
  std::optional<T> push(T value) {
    std::optional<T> evicted;
    const std::size_t slot = (head_ + size_) % slots_.size();
    if (full()) {
      evicted = std::move(slots_[head_]);
      slots_[head_] = std::move(value);
      head_ = (head_ + 1) % slots_.size();
    } else {
      slots_[slot] = std::move(value);
      ++size_;
    }
    return evicted;
  }

  /// i-th entry from the oldest (0) to the newest (size() - 1). Precondition: i < size().
  T& operator[](std::size_t i) { return slots_[(head_ + i) % slots_.size()]; }
  const T& operator[](std::size_t i) const { return slots_[(head_ + i) % slots_.size()]; }
  T& newest() { return (*this)[size_ - 1]; }
  const T& newest() const { return (*this)[size_ - 1]; }

  /// Removes and returns every entry, oldest first.
  std::vector<T> drain() {
    std::vector<T> out;
    out.reserve(size_);
    for (std::size_t i = 0; i < size_; ++i) out.push_back(std::move((*this)[i]));
    clear();
    return out;
  }

  void clear() {
    for (auto& s : slots_) s = T{};
    head_ = 0;
    size_ = 0;
  }

 private:
  std::vector<T> slots_;
  std::size_t head_ = 0;  // index of the oldest entry
  std::size_t size_ = 0;
};

}  // namespace collide::hw
