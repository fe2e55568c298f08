#include "rt_core/runtime/timing_statistics.h"

#include <algorithm>

namespace kcrig {
namespace {

constexpr std::int64_t kFineWidth = 100;      // ns
constexpr int kFineBins = 10000;              // up to 1 ms
constexpr std::int64_t kCoarseWidth = 10000;  // ns
constexpr int kCoarseBins = 9900;             // 1 ms .. 100 ms
constexpr std::int64_t kFineEnd = kFineWidth * kFineBins;

}  // namespace

TimingStatistics::TimingStatistics() : bins_(kFineBins + kCoarseBins, 0) {}

int TimingStatistics::BinOf(std::int64_t ns) {
  if (ns < 0) ns = 0;
  if (ns < kFineEnd) return static_cast<int>(ns / kFineWidth);
  const std::int64_t coarse = (ns - kFineEnd) / kCoarseWidth;
  return kFineBins +
         static_cast<int>(std::min<std::int64_t>(coarse, kCoarseBins - 1));
}

std::int64_t TimingStatistics::LowerEdge(int bin) {
  if (bin < kFineBins) return bin * kFineWidth;
  return kFineEnd + (bin - kFineBins) * kCoarseWidth;
}

std::int64_t TimingStatistics::UpperEdge(int bin) {
  return LowerEdge(bin) + (bin < kFineBins ? kFineWidth : kCoarseWidth);
}

void TimingStatistics::Record(std::int64_t ns) {
  ++bins_[BinOf(ns)];
  if (count_ == 0 || ns < min_) min_ = ns;
  if (count_ == 0 || ns > max_) max_ = ns;
  ++count_;
  sum_ += static_cast<double>(ns);
}

void TimingStatistics::Merge(const TimingStatistics& other) {
  if (other.count_ == 0) return;
  for (size_t bin = 0; bin < bins_.size(); ++bin)
    bins_[bin] += other.bins_[bin];
  min_ = count_ ? std::min(min_, other.min_) : other.min_;
  max_ = std::max(max_, other.max_);
  count_ += other.count_;
  sum_ += other.sum_;
}

double TimingStatistics::mean() const {
  return count_ ? sum_ / static_cast<double>(count_) : 0.0;
}

std::int64_t TimingStatistics::Percentile(double q) const {
  if (count_ == 0) return 0;
  const double target = q * static_cast<double>(count_);
  std::int64_t seen = 0;
  for (int bin = 0; bin < static_cast<int>(bins_.size()); ++bin) {
    seen += bins_[bin];
    if (bins_[bin] > 0 && static_cast<double>(seen) >= target) {
      const bool last = bin + 1 == static_cast<int>(bins_.size());
      return last ? max_ : std::min(UpperEdge(bin), max_);
    }
  }
  return max_;
}

std::vector<std::pair<std::int64_t, std::int64_t>> TimingStatistics::Histogram()
    const {
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  for (int bin = 0; bin < static_cast<int>(bins_.size()); ++bin) {
    if (bins_[bin] > 0) out.emplace_back(LowerEdge(bin), bins_[bin]);
  }
  return out;
}

}  // namespace kcrig
