#pragma once
/// \file
/// Rolling statistics over the most recent samples (cycle times, latencies), allocation-free once
/// constructed.

#include <cstddef>
#include <vector>

namespace hpr {

/// Keeps the last `capacity` samples; percentiles are exact over that window.
class RollingStats {
 public:
  explicit RollingStats(std::size_t capacity = 1000);

  void add(double x);
  void clear();
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t total() const { return total_; }
  /// p in [0, 1]; 0 for an empty window. Nearest-rank percentile.
  [[nodiscard]] double percentile(double p) const;
  [[nodiscard]] double median() const { return percentile(0.5); }
  [[nodiscard]] double max() const;
  [[nodiscard]] double mean() const;

 private:
  std::vector<double> ring_;
  mutable std::vector<double> scratch_;
  std::size_t head_ = 0, size_ = 0, total_ = 0;
};

/// Percentile of a sample set (copies; for tools and tests).
double percentile(std::vector<double> samples, double p);

}  // namespace hpr
