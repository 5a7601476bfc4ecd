// A search against a store of its trials, on synthetic robots whose verdicts are known: what the
// store holds is never run again, whatever part of the search it holds; a search replays to the
// same bracket from its stored verdicts alone; an inconclusive trial is tried again and counted as
// not recovered; specs survive their JSON exactly; and the key separates what must not mix
// (another configuration file, another spec).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "hpr/experiments/bisection.hpp"
#include "hpr/experiments/search.hpp"
#include "scratch_dir.hpp"

namespace {

using namespace hpr::experiments;
namespace fs = std::filesystem;

using hpr::test::ScratchDir;

/// A configuration file of its own for each test (the key hashes its content).
SearchSpec spec_in(const fs::path& dir, const std::string& config_text = "robot: {}\n") {
  const fs::path config = dir / "robot.yaml";
  std::ofstream(config) << config_text;
  SearchSpec s;
  s.base.config = config.string();
  s.base.direction_deg = 45.0;
  s.base.strategy = Strategy::kAnkle;
  s.base.height = 0.9;
  s.base.alpha = 0.8;
  s.base.overrides = {"wbc.gains.com=100", "balance.stepping.enabled=true"};
  s.base.in_process = true;
  s.base.stop_when_decided = true;
  s.start = 15.0;
  s.max_impulse = 80.0;
  s.resolution = 0.5;
  return s;
}

/// A robot that recovers every impulse up to `threshold`, counting the trials it runs.
struct ThresholdTrials {
  double threshold;
  int runs = 0;
  TrialResult operator()(const TrialSpec& s) {
    ++runs;
    TrialResult r;
    r.recovered = s.impulse <= threshold;
    r.completed = true;
    r.failure = r.recovered ? "" : "fell";
    r.return_time = 0.1 * s.impulse;
    return r;
  }
};

std::vector<std::string> lines_of(const fs::path& file) {
  std::vector<std::string> out;
  std::ifstream in(file);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST(Search, FindsWhatTheBisectionFindsAndKeepsEveryTrialInTheStore) {
  const ScratchDir scratch("search-store");
  const fs::path& dir = scratch.path();
  const SearchSpec spec = spec_in(dir);
  const SearchStore store(dir / "trials");
  ThresholdTrials robot{37.3};
  const SearchResult r = run_search(spec, {}, &store, {}, std::ref(robot));
  const ImpulseBracket expected = largest_recovered([](double i) { return i <= 37.3; }, 15.0, 80.0, 0.5);
  EXPECT_EQ(r.bracket.max_recovered, expected.max_recovered);
  EXPECT_EQ(r.bracket.min_lost, expected.min_lost);
  EXPECT_EQ(static_cast<int>(r.trials.size()), robot.runs);
  // A header line, then a line per trial.
  EXPECT_EQ(lines_of(store.file(spec)).size(), r.trials.size() + 1);
  EXPECT_EQ(store.trials(spec).size(), r.trials.size());
  // The trial at the largest recovered impulse keeps its whole result.
  const TrialOutcome* at = r.find(r.bracket.max_recovered);
  ASSERT_NE(at, nullptr);
  EXPECT_DOUBLE_EQ(store.trials(spec).at(r.bracket.max_recovered).result.return_time.value(), 0.1 * r.bracket.max_recovered);
}

TEST(Search, WhatTheStoreHoldsIsNeverRunAgainWhereverTheSearchWasCut) {
  const ScratchDir scratch("search-resume");
  const fs::path& dir = scratch.path();
  const SearchSpec spec = spec_in(dir);
  const SearchStore store(dir / "trials");
  ThresholdTrials first{52.1};
  const SearchResult whole = run_search(spec, {}, &store, {}, std::ref(first));
  const std::vector<std::string> lines = lines_of(store.file(spec));
  // Cut after every number of trials: the rest, and only the rest, runs; the result is the same.
  for (size_t kept = 0; kept <= whole.trials.size(); ++kept) {
    SCOPED_TRACE(kept);
    {
      std::ofstream out(store.file(spec), std::ios::trunc);
      for (size_t i = 0; i <= kept; ++i) out << lines[i] << "\n";
    }
    ThresholdTrials again{52.1};
    const SearchResult r = run_search(spec, store.trials(spec), &store, {}, std::ref(again));
    EXPECT_EQ(again.runs, static_cast<int>(whole.trials.size() - kept));
    EXPECT_EQ(r.bracket.max_recovered, whole.bracket.max_recovered);
    EXPECT_EQ(r.trials.size(), whole.trials.size());
    EXPECT_EQ(store.trials(spec).size(), whole.trials.size());
    // Complete: the replay gives the result without running anything.
    const auto replay = replay_search(spec, store.trials(spec));
    ASSERT_TRUE(replay.has_value());
    EXPECT_EQ(replay->bracket.max_recovered, whole.bracket.max_recovered);
  }
  // One trial missing: no replay.
  auto partial = store.trials(spec);
  partial.erase(whole.trials.back().impulse);
  EXPECT_FALSE(replay_search(spec, partial).has_value());
}

TEST(Search, ALastLineTornByAKilledWriterIsIgnoredAndOneElsewhereIsRefusedNamingTheLine) {
  const ScratchDir scratch("search-torn");
  const fs::path& dir = scratch.path();
  const SearchSpec spec = spec_in(dir);
  const SearchStore store(dir / "trials");
  ThresholdTrials robot{30.0};
  const SearchResult whole = run_search(spec, {}, &store, {}, std::ref(robot));
  std::vector<std::string> lines = lines_of(store.file(spec));
  const std::string torn = lines.back().substr(0, lines.back().size() / 2);
  {
    std::ofstream out(store.file(spec), std::ios::trunc);
    for (size_t i = 0; i + 1 < lines.size(); ++i) out << lines[i] << "\n";
    out << torn;
  }
  EXPECT_EQ(store.trials(spec).size(), whole.trials.size() - 1);
  {
    std::ofstream out(store.file(spec), std::ios::trunc);
    out << lines[0] << "\n" << torn << "\n" << lines[1] << "\n";
  }
  try {
    (void)store.trials(spec);
    FAIL() << "a torn line in the middle was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(store.file(spec).string() + ":2"), std::string::npos) << e.what();
  }
}

TEST(Search, AnInconclusiveTrialRunsAgainAndCountsAsNotRecovered) {
  const ScratchDir scratch("search-inconclusive");
  const fs::path& dir = scratch.path();
  const SearchSpec spec = spec_in(dir);
  int runs = 0, retries = 0;
  SearchEvents events;
  events.retry = [&](const SearchSpec&, double, const std::string&) { ++retries; };
  // Every trial above 20 N s ends before it can tell; the others recover.
  const auto runner = [&](const TrialSpec& s) {
    ++runs;
    if (s.impulse > 20.0) throw std::runtime_error("the stack did not start");
    TrialResult r;
    r.recovered = r.completed = true;
    return r;
  };
  const SearchResult r = run_search(spec, {}, nullptr, events, runner);
  EXPECT_TRUE(r.inconclusive);
  EXPECT_LE(r.bracket.max_recovered, 20.0);
  int inconclusive = 0;
  for (const auto& t : r.trials) {
    if (!t.result.inconclusive) continue;
    ++inconclusive;
    EXPECT_EQ(t.attempts, kTrialAttempts);
    EXPECT_FALSE(t.result.recovered);
    EXPECT_NE(t.result.failure.find("the stack did not start"), std::string::npos) << t.result.failure;
  }
  ASSERT_GT(inconclusive, 0);
  EXPECT_EQ(retries, inconclusive * (kTrialAttempts - 1));
  EXPECT_EQ(runs, static_cast<int>(r.trials.size()) + retries);
}

TEST(Search, ASpecSurvivesItsJsonExactly) {
  const ScratchDir scratch("search-json");
  const fs::path& dir = scratch.path();
  SearchSpec s = spec_in(dir);
  s.base.direction_deg = 1.0 / 3.0;
  s.base.peak = 65.000000000000014;
  s.resolution = 0.1;
  const SearchSpec back = SearchSpec::from_json(s.to_json());
  EXPECT_EQ(back.to_json(), s.to_json());
  EXPECT_EQ(back.base.direction_deg, s.base.direction_deg);
  EXPECT_EQ(back.base.peak, s.base.peak);
  EXPECT_EQ(back.base.height, s.base.height);
  EXPECT_EQ(back.base.alpha, s.base.alpha);
  EXPECT_FALSE(back.base.beta.has_value());
  EXPECT_EQ(back.base.overrides, s.base.overrides);
  EXPECT_EQ(back.base.strategy, Strategy::kAnkle);
  EXPECT_EQ(back.resolution, s.resolution);
  EXPECT_EQ(back.key(), s.key());
}

TEST(Search, TheKeyChangesWithTheSpecAndTheConfigurationsContent) {
  const ScratchDir scratch("search-key");
  const fs::path& dir = scratch.path();
  const SearchSpec s = spec_in(dir);
  const std::string key = s.key();
  EXPECT_EQ(key.size(), 16U);
  EXPECT_EQ(s.key(), key);
  SearchSpec other = s;
  other.base.direction_deg = 90.0;
  EXPECT_NE(other.key(), key);
  other = s;
  other.base.overrides.push_back("wbc.gains.com=200");
  EXPECT_NE(other.key(), key);
  // The impulse is the search's to choose: it is no part of the key.
  other = s;
  other.base.impulse = 42.0;
  EXPECT_EQ(other.key(), key);
  (void)spec_in(dir, "robot: {name: other}\n");
  EXPECT_NE(s.key(), key);
}

}  // namespace
