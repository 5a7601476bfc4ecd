#include "hpr/experiments/dominance.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace hpr::experiments {

namespace {

bool same_push(const DominanceRow& r, const DominanceCell& c) {
  return r.peak == c.peak && r.direction == c.direction && r.support == c.support;
}

std::string figure(const std::optional<double>& v, bool capped) {
  if (!v) return "failed";
  return fmt::format("{:.2f}{}", *v, capped ? "+" : "");
}

std::string push_words(const DominanceRow& r) {
  if (r.support == "double") return fmt::format("double support, {:.0f} deg", r.direction);
  return fmt::format("on the {} foot, {:.0f} deg", r.support, r.direction);
}

}  // namespace

std::vector<DominanceRow> dominance_rows(const std::vector<DominanceCell>& cells, const DominanceLimits& limits) {
  std::vector<DominanceRow> rows;
  for (const DominanceCell& c : cells) {
    if (c.strategy != "cam" && c.strategy != "cam-standing" && c.strategy != "ankle-standing") continue;
    auto it = std::find_if(rows.begin(), rows.end(), [&](const DominanceRow& r) { return same_push(r, c); });
    if (it == rows.end()) {
      DominanceRow row;
      row.peak = c.peak;
      row.direction = c.direction;
      row.support = c.support;
      rows.push_back(row);
      it = rows.end() - 1;
    }
    if (c.strategy == "cam") {
      it->best_default = c.max_recovered;
      it->default_capped = c.reached_max;
    } else if (c.strategy == "cam-standing") {
      it->cam = c.max_recovered;
      it->cam_capped = c.reached_max;
    } else {
      it->ankle = c.max_recovered;
      it->ankle_capped = c.reached_max;
    }
  }
  for (DominanceRow& r : rows) {
    r.dominates = r.best_default && r.cam && r.ankle && *r.best_default >= std::max(*r.cam, *r.ankle) - limits.tolerance;
    const double d = std::fmod(std::fmod(r.direction, 360.0) + 360.0, 360.0);
    r.ratio_applies = r.support == "double" && (d == 0.0 || d == 180.0) && r.cam && r.ankle && !r.cam_capped && !r.ankle_capped;
    r.ratio_met = r.ratio_applies && *r.cam >= limits.ratio * *r.ankle;
  }
  return rows;
}

std::string dominance_table(const std::vector<DominanceCell>& cells, const std::string& config, double cap,
                            double resolution, const DominanceLimits& limits) {
  const std::vector<DominanceRow> rows = dominance_rows(cells, limits);
  std::string out = fmt::format(
      "Largest recovered impulse [N s] of {}: the default (CAM strategy as configured, stepping when it steps) against "
      "the CAM strategy and the ankle strategy standing (stepping off, the same posture); bisection to {} N s, cap {} N s "
      "(+: the cap recovered). Checks: default >= max(standing) - {} N s; CAM / ankle >= {} from behind and from the "
      "front in double support where neither reached the cap.\n",
      config, resolution, cap, limits.tolerance, limits.ratio);
  std::vector<double> peaks;
  for (const auto& r : rows) {
    if (std::find(peaks.begin(), peaks.end(), r.peak) == peaks.end()) peaks.push_back(r.peak);
  }
  for (double peak : peaks) {
    out += fmt::format("\n### {:.0f} N peak\n\n| push | default | CAM standing | ankle standing | default >= max - {} | CAM / ankle |\n"
                       "|---|---|---|---|---|---|\n",
                       peak, limits.tolerance);
    for (const auto& r : rows) {
      if (r.peak != peak) continue;
      std::string ratio = "-";
      if (r.cam && r.ankle && *r.ankle > 0) {
        ratio = fmt::format("{:.2f}{}", *r.cam / *r.ankle, r.ratio_applies ? (r.ratio_met ? "" : " **below**") : "");
      }
      out += fmt::format("| {} | {} | {} | {} | {} | {} |\n", push_words(r), figure(r.best_default, r.default_capped),
                         figure(r.cam, r.cam_capped), figure(r.ankle, r.ankle_capped), r.dominates ? "yes" : "**no**", ratio);
    }
  }
  std::string failures;
  for (const auto& r : rows) {
    if (!r.dominates) {
      failures += fmt::format("- {:.0f} N, {}: the default {} N s against {} / {} N s standing\n", r.peak, push_words(r),
                              figure(r.best_default, r.default_capped), figure(r.cam, r.cam_capped), figure(r.ankle, r.ankle_capped));
    }
    if (r.ratio_applies && !r.ratio_met) {
      failures += fmt::format("- {:.0f} N, {}: CAM / ankle standing {:.2f} (below {})\n", r.peak, push_words(r), *r.cam / *r.ankle,
                              limits.ratio);
    }
  }
  out += failures.empty() ? "\nEvery check holds.\n" : "\nChecks that fail:\n\n" + failures;
  return out;
}

}  // namespace hpr::experiments
