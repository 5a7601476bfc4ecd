#include "hpr/experiments/search.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstdint>
#include <ctime>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "hpr/experiments/version.hpp"

namespace hpr::experiments {

namespace fs = std::filesystem;
using nlohmann::ordered_json;

namespace {

ordered_json spec_json(const TrialSpec& s) {
  ordered_json j;
  j["config"] = s.config;
  j["support"] = s.support;
  j["strategy"] = to_string(s.strategy);
  j["direction_deg"] = s.direction_deg;
  j["impulse_Ns"] = s.impulse;
  j["peak_N"] = s.peak;
  j["duration_s"] = s.duration;
  j["link"] = s.link;
  if (s.height) j["height_m"] = *s.height;
  if (s.alpha) j["alpha"] = *s.alpha;
  if (s.beta) j["beta"] = *s.beta;
  j["push_time_s"] = s.push_time;
  j["after_s"] = s.after;
  j["overrides"] = s.overrides;
  j["log_file"] = s.log_file;
  j["work_dir"] = s.work_dir;
  j["timeout_s"] = s.timeout;
  j["stop_when_decided"] = s.stop_when_decided;
  j["in_process"] = s.in_process;
  j["truth_state"] = s.truth_state;
  return j;
}

TrialSpec spec_from(const nlohmann::json& j) {
  TrialSpec s;
  s.config = j.at("config").get<std::string>();
  s.support = j.at("support").get<std::string>();
  s.strategy = strategy_from_string(j.at("strategy").get<std::string>());
  s.direction_deg = j.at("direction_deg").get<double>();
  s.impulse = j.at("impulse_Ns").get<double>();
  s.peak = j.at("peak_N").get<double>();
  s.duration = j.at("duration_s").get<double>();
  s.link = j.at("link").get<std::string>();
  if (j.contains("height_m")) s.height = j.at("height_m").get<double>();
  if (j.contains("alpha")) s.alpha = j.at("alpha").get<double>();
  if (j.contains("beta")) s.beta = j.at("beta").get<double>();
  s.push_time = j.at("push_time_s").get<double>();
  s.after = j.at("after_s").get<double>();
  s.overrides = j.at("overrides").get<std::vector<std::string>>();
  s.log_file = j.at("log_file").get<std::string>();
  s.work_dir = j.at("work_dir").get<std::string>();
  s.timeout = j.at("timeout_s").get<double>();
  s.stop_when_decided = j.at("stop_when_decided").get<bool>();
  s.in_process = j.at("in_process").get<bool>();
  s.truth_state = j.at("truth_state").get<bool>();
  return s;
}

ordered_json search_json(const SearchSpec& s) {
  TrialSpec base = s.base;
  base.impulse = 0.0;  // the search chooses it
  ordered_json j;
  j["trial"] = spec_json(base);
  j["start_Ns"] = s.start;
  j["max_impulse_Ns"] = s.max_impulse;
  j["resolution_Ns"] = s.resolution;
  return j;
}

/// FNV-1a, 64 bits.
std::uint64_t fnv1a(const std::string& text, std::uint64_t h = 14695981039346656037ULL) {
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return h;
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string now_text() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// Thrown by replay_search's runner: the store does not hold the trial.
struct NotKnown {};

}  // namespace

std::string trial_spec_to_json(const TrialSpec& spec) { return spec_json(spec).dump(); }
TrialSpec trial_spec_from_json(const std::string& json) { return spec_from(nlohmann::json::parse(json)); }

std::string SearchSpec::to_json() const { return search_json(*this).dump(); }

SearchSpec SearchSpec::from_json(const std::string& json) {
  const nlohmann::json j = nlohmann::json::parse(json);
  SearchSpec s;
  s.base = spec_from(j.at("trial"));
  s.start = j.at("start_Ns").get<double>();
  s.max_impulse = j.at("max_impulse_Ns").get<double>();
  s.resolution = j.at("resolution_Ns").get<double>();
  return s;
}

std::string SearchSpec::key() const {
  std::uint64_t h = fnv1a(std::string(source_commit()) + "\n");
  h = fnv1a(to_json() + "\n", h);
  h = fnv1a(file_text(base.config), h);
  return fmt::format("{:016x}", h);
}

std::string SearchSpec::label() const {
  return fmt::format("{} {} {:.0f} deg", base.support, to_string(base.strategy), base.direction_deg);
}

const TrialOutcome* SearchResult::find(double impulse) const {
  for (const auto& t : trials) {
    if (t.impulse == impulse) return &t;
  }
  return nullptr;
}

SearchStore::SearchStore(fs::path dir) : dir_(std::move(dir)) { fs::create_directories(dir_); }

fs::path SearchStore::file(const SearchSpec& spec) const { return dir_ / (spec.key() + ".jsonl"); }

std::map<double, TrialOutcome> SearchStore::trials(const SearchSpec& spec) const {
  std::map<double, TrialOutcome> out;
  const fs::path path = file(spec);
  std::ifstream in(path);
  if (!in) return out;
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::string expected = spec.to_json();
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].empty()) continue;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(lines[i]);
    } catch (const nlohmann::json::exception& e) {
      if (i + 1 == lines.size()) break;  // the last line, torn by a writer that was killed
      throw std::runtime_error(fmt::format("{}:{}: not a JSON line ({})", path.string(), i + 1, e.what()));
    }
    try {
      if (j.contains("search")) {
        if (j.at("search").dump() != nlohmann::json::parse(expected).dump()) {
          throw std::runtime_error("the file holds another search");
        }
        continue;
      }
      TrialOutcome t;
      t.impulse = j.at("impulse_Ns").get<double>();
      t.attempts = j.at("attempts").get<int>();
      t.result = TrialResult::from_json(j.at("result").dump());
      out[t.impulse] = t;
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("{}:{}: {}", path.string(), i + 1, e.what()));
    }
  }
  return out;
}

void SearchStore::append(const SearchSpec& spec, const TrialOutcome& trial) const {
  const fs::path path = file(spec);
  const bool fresh = !fs::exists(path) || fs::file_size(path) == 0;
  std::ofstream out(path, std::ios::app);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  if (fresh) {
    ordered_json h;
    h["search"] = search_json(spec);
    h["commit"] = source_commit();
    h["created"] = now_text();
    out << h.dump() << "\n";
  }
  TrialSpec at = spec.base;
  at.impulse = trial.impulse;
  ordered_json j;
  j["impulse_Ns"] = trial.impulse;
  j["attempts"] = trial.attempts;
  j["result"] = ordered_json::parse(trial.result.to_json(at));
  out << j.dump() << std::endl;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

namespace {

/// The search against `known`; trials it does not hold run through `runner`, or, without one,
/// end the search with NotKnown.
SearchResult search(const SearchSpec& spec, const std::map<double, TrialOutcome>& known, const SearchStore* store,
                    const SearchEvents& events, const TrialRunner* runner) {
  SearchResult out;
  const auto recovered = [&](double impulse) {
    if (const auto it = known.find(impulse); it != known.end()) {
      out.trials.push_back(it->second);
      out.inconclusive = out.inconclusive || it->second.result.inconclusive;
      if (events.trial) events.trial(spec, it->second, true);
      return it->second.result.recovered;
    }
    if (runner == nullptr) throw NotKnown{};
    TrialSpec s = spec.base;
    s.impulse = impulse;
    TrialOutcome o;
    o.impulse = impulse;
    // A run that ended before it could tell (a stack that failed, a machine that held it up past
    // the time limit) says nothing about the robot: it is run again.
    for (o.attempts = 1; o.attempts <= kTrialAttempts; ++o.attempts) {
      try {
        o.result = (*runner)(s);
      } catch (const std::exception& e) {
        o.result = TrialResult{};
        o.result.inconclusive = true;
        o.result.failure = e.what();
      }
      if (!o.result.inconclusive || o.attempts == kTrialAttempts) break;
      if (events.retry) events.retry(spec, impulse, o.result.failure);
    }
    if (o.result.inconclusive) {
      o.result.recovered = false;
      o.result.failure = "inconclusive, counted as not recovered: " + o.result.failure;
      out.inconclusive = true;
    }
    if (store != nullptr) store->append(spec, o);
    out.trials.push_back(o);
    if (events.trial) events.trial(spec, o, false);
    return o.result.recovered;
  };
  out.bracket = largest_recovered(recovered, spec.start, spec.max_impulse, spec.resolution);
  return out;
}

}  // namespace

SearchResult run_search(const SearchSpec& spec, const std::map<double, TrialOutcome>& known, const SearchStore* store,
                        const SearchEvents& events, TrialRunner runner) {
  // The default runner: in process, the search's trials continue one run from just before the
  // push (built on the first trial that `known` does not answer).
  std::unique_ptr<PrePushCheckpoint> checkpoint;
  bool checkpoint_tried = false;
  if (!runner) {
    runner = [&](const TrialSpec& s) {
      if (!checkpoint_tried) {
        checkpoint_tried = true;
        checkpoint = PrePushCheckpoint::for_case(s);  // the base with a push: the spec read back has none
      }
      return checkpoint ? checkpoint->run(s) : run_trial(s);
    };
  }
  return search(spec, known, store, events, &runner);
}

std::optional<SearchResult> replay_search(const SearchSpec& spec, const std::map<double, TrialOutcome>& known) {
  try {
    return search(spec, known, nullptr, {}, nullptr);
  } catch (const NotKnown&) {
    return std::nullopt;
  }
}

}  // namespace hpr::experiments
