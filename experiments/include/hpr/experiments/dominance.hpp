#pragma once
/// \file The dominance table (push_sweep --dominance): per peak force and per push, the largest
/// recovered impulse of the default controller ("cam": the CAM strategy as configured, stepping
/// when the configuration steps) against each single strategy standing ("cam-standing",
/// "ankle-standing": stepping off, the same posture), and the two checks the shipped configuration
/// must pass:
///   - the escalation never costs a push that a single strategy holds:
///       default >= max(cam-standing, ankle-standing) - tolerance;
///   - the hip strategy is worth it (the paper's claim), in double support pushed from behind or
///     from the front, where neither standing strategy reached the sweep's cap:
///       cam-standing >= ratio * ankle-standing.

#include <optional>
#include <string>
#include <vector>

namespace hpr::experiments {

/// One finished search of the sweep.
struct DominanceCell {
  std::string support;   ///< double | left | right
  std::string strategy;  ///< cam | cam-standing | ankle-standing (others are ignored)
  double peak = 0.0;     ///< [N]
  double direction = 0.0;  ///< [deg]
  std::optional<double> max_recovered;  ///< [N s]; none: the search did not finish
  bool reached_max = false;             ///< the cap was recovered
};

struct DominanceLimits {
  double tolerance = 0.5;  ///< [N s] the default may be this far below the better single strategy
  double ratio = 1.25;     ///< cam-standing / ankle-standing in the sagittal double-support cells
};

/// One push (peak, support, direction) with the three strategies' limits.
struct DominanceRow {
  double peak = 0.0, direction = 0.0;
  std::string support;
  std::optional<double> best_default, cam, ankle;  ///< [N s]
  bool default_capped = false, cam_capped = false, ankle_capped = false;
  /// default >= max(cam, ankle) - tolerance (false when a figure is missing).
  bool dominates = false;
  /// The sagittal double-support rows where neither standing strategy reached the cap.
  bool ratio_applies = false;
  bool ratio_met = false;
};

/// The rows in the cells' order of first appearance, each check evaluated.
std::vector<DominanceRow> dominance_rows(const std::vector<DominanceCell>& cells, const DominanceLimits& limits = {});

/// The table as Markdown: one table per peak, then the rows that fail a check.
std::string dominance_table(const std::vector<DominanceCell>& cells, const std::string& config, double cap,
                            double resolution, const DominanceLimits& limits = {});

}  // namespace hpr::experiments
