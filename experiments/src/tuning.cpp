#include "hpr/experiments/tuning.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"

namespace hpr::experiments {

namespace {

constexpr TunedParam kParams[] = {
    {"alpha", "reference_gen.alpha", 0.5, 1.0, false, "activation threshold (23)"},
    {"beta", "reference_gen.beta", 0.1, 1.0, false, "reduction rate (27)"},
    {"Q_l", "motion_opt.weights.cam", 0.1, 30.0, true, "CAM weight (14a)"},
    {"Q_p", "motion_opt.weights.posture", 0.01, 5.0, true, "posture weight (14b)"},
    {"K_p", "motion_opt.gains.posture", 0.3, 20.0, true, "posture gain (16) [1/s]"},
    {"K_a", "motion_opt.gains.limits", 1.0, 50.0, true, "limit gain (17) [1/s]"},
    {"lean_y_neg", "reference_gen.y.lean_budget_negative", 0.3, 30.0, true, "lean budget about y, l < 0 [N m s^2]", true},
    {"lean_y_pos", "reference_gen.y.lean_budget_positive", 0.3, 30.0, true, "lean budget about y, l > 0 [N m s^2]", true},
};

}  // namespace

std::span<const TunedParam> tuned_params() { return kParams; }

const TunedParam& tuned_param(const std::string& name) {
  for (const auto& p : kParams) {
    if (name == p.name) return p;
  }
  std::string known;
  for (const auto& p : kParams) known += std::string(known.empty() ? "" : ", ") + p.name;
  throw UsageError("--params: unknown parameter '" + name + "' (known: " + known + ")");
}

double to_unit(const TunedParam& p, double v) {
  v = std::clamp(v, p.lo, p.hi);
  return p.log_scale ? std::log(v / p.lo) / std::log(p.hi / p.lo) : (v - p.lo) / (p.hi - p.lo);
}

double from_unit(const TunedParam& p, double u) {
  u = std::clamp(u, 0.0, 1.0);
  if (p.off_at_top && u >= 1.0) return std::numeric_limits<double>::infinity();
  return p.log_scale ? p.lo * std::pow(p.hi / p.lo, u) : p.lo + u * (p.hi - p.lo);
}

double configured_value(const Config& cfg, const TunedParam& p) {
  const std::string key = p.key;
  const auto dot = key.find('.');
  const Config section = cfg.section(key.substr(0, dot));
  const std::string rest = key.substr(dot + 1);
  const auto dot2 = rest.find('.');
  if (dot2 == std::string::npos) return section.real(rest);
  const std::string sub_name = rest.substr(0, dot2), leaf = rest.substr(dot2 + 1);
  const bool set = section.has(sub_name) && section.section(sub_name).has(leaf);
  if (p.off_at_top && !set) return std::numeric_limits<double>::infinity();
  const Config sub = section.section(sub_name);
  try {
    return sub.real(leaf);
  } catch (const std::exception&) {
    return sub.reals(leaf).at(0);
  }
}

std::string value_text(double v) { return std::isinf(v) ? std::string(".inf") : fmt::format("{:.6g}", v); }

double text_value(const std::string& t) { return t == ".inf" ? std::numeric_limits<double>::infinity() : std::stod(t); }

}  // namespace hpr::experiments
