#pragma once
// The parameters push_tune searches (README.md, "Tools"): their configuration keys and
// bounds, the unit cube the optimiser works in, and the text a value is written as.
#include <span>
#include <string>

namespace hpr {
class Config;
}

namespace hpr::experiments {

/// A tuned parameter: its configuration key, bounds, and whether the search runs on its logarithm.
struct TunedParam {
  const char* name;
  const char* key;  ///< "section.key" or "section.sub.key"
  double lo, hi;
  bool log_scale;
  const char* what;
  bool off_at_top = false;  ///< the top of the range stands for ∞ (the bound switched off)
};

/// Every parameter push_tune knows.
std::span<const TunedParam> tuned_params();
/// The parameter called `name`; hpr::UsageError naming the known ones otherwise.
const TunedParam& tuned_param(const std::string& name);

/// `v` in the unit interval of `p`'s range (linear, or logarithmic), clamped to it.
double to_unit(const TunedParam& p, double v);
/// The inverse of to_unit; ∞ at the top of a range whose top switches the bound off.
double from_unit(const TunedParam& p, double u);
/// The configured value of `p`, overrides applied (the first entry of a per-axis list); ∞ for a
/// bound that is off unless configured.
double configured_value(const Config& cfg, const TunedParam& p);

/// A value as written in results and overlays: 6 significant digits, ".inf" for ∞ (YAML's).
std::string value_text(double v);
/// The inverse of value_text.
double text_value(const std::string& t);

}  // namespace hpr::experiments
