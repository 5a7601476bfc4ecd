#include "hpr/common/stats.hpp"

#include <algorithm>
#include <cmath>

namespace hpr {

RollingStats::RollingStats(std::size_t capacity) : ring_(capacity == 0 ? 1 : capacity), scratch_(ring_.size()) {}

void RollingStats::add(double x) {
  ring_[head_] = x;
  head_ = (head_ + 1) % ring_.size();
  size_ = std::min(size_ + 1, ring_.size());
  ++total_;
}

void RollingStats::clear() {
  head_ = size_ = 0;
}

double RollingStats::percentile(double p) const {
  if (size_ == 0) return 0.0;
  std::copy_n(ring_.begin(), size_, scratch_.begin());
  const auto rank = static_cast<std::size_t>(std::ceil(std::clamp(p, 0.0, 1.0) * static_cast<double>(size_)));
  const std::size_t k = rank == 0 ? 0 : rank - 1;
  std::nth_element(scratch_.begin(), scratch_.begin() + static_cast<std::ptrdiff_t>(k),
                   scratch_.begin() + static_cast<std::ptrdiff_t>(size_));
  return scratch_[k];
}

double RollingStats::max() const {
  if (size_ == 0) return 0.0;
  return *std::max_element(ring_.begin(), ring_.begin() + static_cast<std::ptrdiff_t>(size_));
}

double RollingStats::mean() const {
  if (size_ == 0) return 0.0;
  double s = 0;
  for (std::size_t i = 0; i < size_; ++i) s += ring_[i];
  return s / static_cast<double>(size_);
}

double percentile(std::vector<double> samples, double p) {
  if (samples.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(std::clamp(p, 0.0, 1.0) * static_cast<double>(samples.size())));
  const std::size_t k = rank == 0 ? 0 : rank - 1;
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(k), samples.end());
  return samples[k];
}

}  // namespace hpr
