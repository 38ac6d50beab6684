// A series of samples kept in bounded memory for a process that runs for
// days: every value while fewer than `capacity` have come, then one of
// every two, one of every four, and so on. The values are taken in blocks
// of `stride` and one of each block is kept, chosen at random; when the
// kept values fill the capacity, one of each two neighbours is kept (again
// at random) and the stride doubles. So what is kept is a stratified
// sample spread evenly over the whole run, one value of each block, each
// value of a block as likely as the others: a percentile over it estimates
// the run's (and is the run's exactly until the first halving), and a
// series with a period (every other frame slow) is not seen in one phase
// only, as a fixed stride would. Never more than `capacity` values; the
// storage is reserved at the first value, so a long run's memory stays
// where it was after its first sample. The choices are drawn from a fixed
// seed: the same series keeps the same values.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace holofuse {

template <typename T>
class DecimatedSeries {
 public:
  static constexpr size_t kDefaultCapacity = 2048;

  // capacity: even, at least 2.
  explicit DecimatedSeries(size_t capacity = kDefaultCapacity)
      : capacity_(capacity < 2 ? 2 : capacity + capacity % 2) {}

  void add(const T& value) {
    const uint64_t in_block = count_++ % stride_;
    if (in_block == 0) pick_ = stride_ == 1 ? 0 : random() % stride_;
    if (in_block != pick_) return;
    if (kept_.capacity() < capacity_) kept_.reserve(capacity_);
    kept_.push_back(value);
    if (kept_.size() < capacity_) return;
    // The block just filled ends at a multiple of twice the stride (the
    // capacity is even), so the next value begins a block of the new one.
    for (size_t i = 0; i < capacity_ / 2; ++i) kept_[i] = kept_[2 * i + (random() & 1)];
    kept_.resize(capacity_ / 2);
    stride_ *= 2;
  }

  // The values kept, in the order they came: the i-th from the values
  // numbered [i * stride(), (i + 1) * stride()).
  const std::vector<T>& kept() const { return kept_; }
  // For values that are corrected after the fact (a clock estimate refined).
  std::vector<T>& kept() { return kept_; }
  // Every value added, kept or not.
  uint64_t count() const { return count_; }
  uint64_t stride() const { return stride_; }
  bool empty() const { return count_ == 0; }

 private:
  // SplitMix64 (Steele, Lea and Flood 2014): small, fast, well mixed.
  uint64_t random() {
    uint64_t z = (seed_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  size_t capacity_;
  std::vector<T> kept_;
  uint64_t count_ = 0;
  uint64_t stride_ = 1;
  uint64_t pick_ = 0;  // the place in the current block of the value kept
  uint64_t seed_ = 0x5EED;
};

}  // namespace holofuse
