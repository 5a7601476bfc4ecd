#include "hpr/common/parameters.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hpr {

void ParameterSet::add(Parameter p) {
  if (!p.get || !p.set) throw std::logic_error("parameter " + node_ + "." + p.key + " needs a getter and a setter");
  if (!(p.min_value <= p.max_value)) throw std::logic_error("parameter " + node_ + "." + p.key + " has an empty range");
  if (find(p.key) != nullptr) throw std::logic_error("parameter " + node_ + "." + p.key + " registered twice");
  parameters_.push_back(std::move(p));
}

void ParameterSet::add(const std::string& key, double& value, double min_value, double max_value,
                       const std::string& unit, std::function<void()> on_change) {
  double* v = &value;
  add(Parameter{key, unit, min_value, max_value, [v] { return *v; },
                [v, on_change = std::move(on_change)](double x) {
                  *v = x;
                  if (on_change) on_change();
                  return std::string();
                }});
}

void ParameterSet::add_xyz(const std::string& key, double* xyz, double min_value, double max_value,
                           const std::string& unit) {
  add(key + ".x", xyz[0], min_value, max_value, unit);
  add(key + ".y", xyz[1], min_value, max_value, unit);
  add(key + ".z", xyz[2], min_value, max_value, unit);
}

const Parameter* ParameterSet::find(const std::string& key) const {
  const auto it = std::find_if(parameters_.begin(), parameters_.end(), [&](const Parameter& p) { return p.key == key; });
  return it == parameters_.end() ? nullptr : &*it;
}

ParameterSetResult ParameterSet::apply(const std::vector<std::string>& names, const std::vector<double>& values) {
  ParameterSetResult r;
  const std::string prefix = node_ + ".";
  struct Change {
    const Parameter* p;
    double value, old;
  };
  std::vector<Change> changes;
  std::string error;
  const std::size_t n = std::min(names.size(), values.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (names[i].rfind(prefix, 0) != 0) continue;
    r.addressed = true;
    if (!error.empty()) continue;
    const std::string key = names[i].substr(prefix.size());
    const double v = values[i];
    const Parameter* p = find(key);
    if (p == nullptr) {
      std::string known;
      for (const auto& q : parameters_) known += (known.empty() ? "" : ", ") + q.key;
      error = fmt::format("{}: no such live parameter (this node has: {})", names[i], known.empty() ? "none" : known);
    } else if (!std::isfinite(v)) {
      error = fmt::format("{} = {}: not a finite number", names[i], v);
    } else if (v < p->min_value || v > p->max_value) {
      error = fmt::format("{} = {}: outside [{}, {}]{}", names[i], v, p->min_value, p->max_value,
                          p->unit.empty() ? "" : " " + p->unit);
    } else {
      changes.push_back({p, v, 0.0});
    }
  }
  if (!r.addressed) return r;
  if (error.empty()) {
    // Apply in order; a setter that refuses undoes the ones before it, newest first (a pair with
    // a cross constraint comes back in the order that keeps it). A key that stands for several
    // (reference_gen's "alpha" for three axes) reads NaN while they differ and cannot be restored
    // itself: the values every parameter had before the set restore what it changed.
    std::vector<double> before;
    before.reserve(parameters_.size());
    for (const auto& q : parameters_) before.push_back(q.get());
    for (std::size_t k = 0; k < changes.size(); ++k) {
      auto& c = changes[k];
      c.old = c.p->get();
      const std::string why = c.p->set(c.value);
      if (!why.empty()) {
        error = fmt::format("{}{} = {}: {}", prefix, c.p->key, c.value, why);
        for (std::size_t u = k; u-- > 0;) {
          if (std::isfinite(changes[u].old)) changes[u].p->set(changes[u].old);
        }
        for (std::size_t i = 0; i < parameters_.size(); ++i) {
          const double now = parameters_[i].get();
          if (std::isfinite(before[i]) && now != before[i]) parameters_[i].set(before[i]);
        }
        break;
      }
    }
  }
  if (!error.empty()) {
    r.text = "nothing changed: " + error;
    return r;
  }
  r.applied = true;
  ++version_;
  for (const auto& c : changes) {
    if (c.old != c.value) ++r.changed;
    r.text += fmt::format("{}{} {} -> {}{}", r.text.empty() ? "" : ", ", c.p->key, c.old, c.value,
                          c.p->unit.empty() ? "" : " " + c.p->unit);
  }
  return r;
}

}  // namespace hpr
