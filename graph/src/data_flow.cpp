#include "hpr/graph/data_flow.hpp"

#include <algorithm>
#include <array>
#include <deque>
#include <stdexcept>

#include "hpr/estimator/estimator.hpp"
#include "hpr/estimator/truth_state.hpp"
#include "hpr/hal/ports.hpp"
#include "hpr/motion_opt/component.hpp"
#include "hpr/planner/component.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/sim/ports.hpp"
#include "hpr/wbc/component.hpp"

namespace hpr::graph {

namespace {

/// Storage of the composed ports (their reads, writes and texts), alive for the program.
struct ComposedStore {
  std::deque<std::vector<Read>> reads;
  std::deque<std::vector<std::string_view>> writes;
  std::deque<std::string> texts;
};

ComposedStore& store() {
  static ComposedStore s;
  return s;
}

}  // namespace

Ports composed(std::string_view name, std::span<const Ports> parts) {
  ComposedStore& s = store();
  std::vector<std::string_view>& writes = s.writes.emplace_back();
  for (const Ports& p : parts) {
    for (std::string_view w : p.writes) {
      if (std::find(writes.begin(), writes.end(), w) == writes.end()) writes.push_back(w);
    }
  }
  std::vector<Read>& reads = s.reads.emplace_back();
  std::vector<std::string> uses;
  for (const Ports& p : parts) {
    for (const Read& r : p.reads) {
      if (std::find(writes.begin(), writes.end(), r.channel) != writes.end()) continue;  // passed inside
      const std::string use = std::string(p.name) + ": " + std::string(r.use);
      auto it = std::find_if(reads.begin(), reads.end(), [&](const Read& x) { return x.channel == r.channel; });
      if (it == reads.end()) {
        reads.push_back(r);
        uses.push_back(use);
        continue;
      }
      // Several parts read it: one read, stepping if any part steps on it, optional if all can do without.
      const auto i = static_cast<std::size_t>(it - reads.begin());
      if (it->tick_offset != r.tick_offset) {
        throw std::logic_error(std::string(name) + ": its parts read " + std::string(r.channel) + " at different ticks");
      }
      it->trigger = it->trigger || r.trigger;
      it->optional = it->optional && r.optional;
      uses[i] += "; " + use;
    }
  }
  for (std::size_t i = 0; i < reads.size(); ++i) reads[i].use = s.texts.emplace_back(std::move(uses[i]));
  return {s.texts.emplace_back(name), reads, writes};
}

const Ports& controllers_ports() {
  static const Ports p = [] {
    const std::array parts = {estimator::Estimator::kPorts, planner::BalancePlanner::kPorts, reference_gen::ReferenceGenerator::kPorts,
                              motion_opt::MotionOptComponent::kPorts, wbc::WbcComponent::kPorts};
    return composed("controllers", parts);
  }();
  return p;
}

std::span<const Ports> data_flow() {
  static const std::array kFlow = {sim::kPorts,
                                   sim::kMujocoPorts,
                                   hal::kPorts,
                                   hal::kEmulatorPorts,
                                   estimator::Estimator::kPorts,
                                   estimator::TruthState::kPorts,
                                   planner::BalancePlanner::kPorts,
                                   reference_gen::ReferenceGenerator::kPorts,
                                   motion_opt::MotionOptComponent::kPorts,
                                   wbc::WbcComponent::kPorts,
                                   controllers_ports()};
  return kFlow;
}

const Ports* find_process(std::string_view name) {
  for (const auto& p : data_flow()) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const Read& read_of(std::string_view process, std::string_view channel) {
  const Ports* p = find_process(process);
  if (p == nullptr) throw std::invalid_argument("'" + std::string(process) + "' is not a process of the stack");
  return p->at(channel);
}

std::vector<std::string> unmet_inputs(const std::vector<std::string>& processes) {
  std::vector<std::string_view> written;
  for (const auto& n : processes) {
    if (const Ports* p = find_process(n)) written.insert(written.end(), p->writes.begin(), p->writes.end());
  }
  std::vector<std::string> unmet;
  for (const auto& n : processes) {
    const Ports* p = find_process(n);
    if (p == nullptr) continue;
    for (const auto& r : p->reads) {
      if (r.optional || std::find(written.begin(), written.end(), r.channel) != written.end()) continue;
      unmet.push_back(n + " reads " + std::string(r.channel) + " (" + std::string(r.use) + "), which none of them writes");
    }
  }
  return unmet;
}

}  // namespace hpr::graph
