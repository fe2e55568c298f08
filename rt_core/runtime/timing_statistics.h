// Per-phase timing statistics of the real-time loop: min, mean, max and a
// fixed histogram from which the percentiles come. Recording is O(1) and
// allocation-free (the histogram is allocated at construction), so it runs
// inside the cycle. Resolution: 100 ns up to 1 ms, 10 us up to 100 ms;
// longer durations land in the last bin (max stays exact).
#ifndef KCRIG_RT_CORE_RUNTIME_TIMING_STATISTICS_H_
#define KCRIG_RT_CORE_RUNTIME_TIMING_STATISTICS_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace kcrig {

class TimingStatistics {
 public:
  TimingStatistics();

  void Record(std::int64_t nanoseconds);
  // Adds every sample of `other`.
  void Merge(const TimingStatistics& other);

  std::int64_t count() const { return count_; }
  // All in nanoseconds; 0 when nothing was recorded.
  std::int64_t min() const { return count_ ? min_ : 0; }
  std::int64_t max() const { return max_; }
  double mean() const;
  // The smallest bin upper edge below which a fraction q of the samples lie
  // (q in (0, 1]); exact to the bin width, capped at max().
  std::int64_t Percentile(double q) const;
  // (bin lower edge [ns], count) of the non-empty bins, ascending.
  std::vector<std::pair<std::int64_t, std::int64_t>> Histogram() const;

 private:
  static int BinOf(std::int64_t nanoseconds);
  static std::int64_t LowerEdge(int bin);
  static std::int64_t UpperEdge(int bin);

  std::vector<std::int64_t> bins_;
  std::int64_t count_ = 0;
  std::int64_t min_ = 0;
  std::int64_t max_ = 0;
  double sum_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_TIMING_STATISTICS_H_
