// push_task: one array task of a sweep or a tune on a Slurm cluster (docs/CLUSTER.md). Runs its
// share of a round's searches through the same executor push_sweep runs locally, appending every
// trial to the shared store as it finishes; the trials the store holds already (a task submitted
// again after a failure or a time limit) are not run again.
#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/log.hpp"
#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/version.hpp"

namespace {

using namespace hpr::experiments;

void usage(std::FILE* out) {
  std::fputs(R"(usage: push_task --searches FILE --task I --store DIR [--per-task K] [--jobs J] [--commit C]

Runs searches I*K to I*K+K-1 (counted from 0) of FILE, one search per line as push_sweep and
push_tune write them, J at a time, each trial appended to DIR/<search key>.jsonl as it finishes.
With --commit, refuses to run unless built from commit C (the submitting tool's: a node that runs
another build would file its trials where the submitter never looks).
Exit status: 0 when every search finished, 1 when one could not run, 2 for bad arguments.
)",
             out);
}

}  // namespace

int main(int argc, char** argv) {
  std::string searches_file, store, commit;
  int task = -1, per_task = 1, jobs = 1;
  const auto option = [&](hpr::ArgReader& args) {
    if (args.is("--searches")) {
      searches_file = args.value();
    } else if (args.is("--task")) {
      task = args.integer();
    } else if (args.is("--per-task")) {
      per_task = args.integer();
    } else if (args.is("--store")) {
      store = args.value();
    } else if (args.is("--jobs")) {
      jobs = args.integer();
    } else if (args.is("--commit")) {
      commit = args.value();
    } else {
      args.unknown();
    }
  };
  const auto check = [&] {
    if (searches_file.empty() || store.empty() || task < 0) throw hpr::UsageError("--searches, --task and --store are required");
    if (per_task < 1 || jobs < 1) throw hpr::UsageError("--per-task and --jobs: at least 1");
  };
  if (const auto status = hpr::read_command_line(argc, argv, "push_task", usage, option, check)) return *status;
  if (!commit.empty() && commit != source_commit()) {
    std::fprintf(stderr,
                 "push_task: built from %s, but the searches were written by a build from %s: the nodes must run the "
                 "submitting machine's build (a shared build tree or install, or --task-exe)\n",
                 source_commit(), commit.c_str());
    return 1;
  }
  hpr::log::init("push_task", hpr::log::Level::kError);
  std::vector<SearchSpec> mine;
  {
    std::ifstream in(searches_file);
    if (!in) {
      std::fprintf(stderr, "push_task: cannot read %s\n", searches_file.c_str());
      return 1;
    }
    int line_no = 0;
    for (std::string line; std::getline(in, line);) {
      const int i = line_no++;
      if (i / per_task != task) continue;
      try {
        mine.push_back(SearchSpec::from_json(line));
      } catch (const std::exception& e) {
        std::fprintf(stderr, "push_task: %s:%d: %s\n", searches_file.c_str(), i + 1, e.what());
        return 1;
      }
    }
  }
  if (mine.empty()) {
    std::fprintf(stderr, "push_task: %s has no search for task %d (%d per task)\n", searches_file.c_str(), task, per_task);
    return 1;
  }
  ExecutorEvents events;
  events.trial = [](const SearchSpec& s, const TrialOutcome& t, bool stored) {
    std::printf("%s %.2f N s: %s%s\n", s.label().c_str(), t.impulse,
                t.result.recovered ? "recovered" : ("not recovered (" + t.result.failure + ")").c_str(), stored ? " [stored]" : "");
    std::fflush(stdout);
  };
  events.search = [](const SearchSpec& s, const SearchResult& r) {
    std::printf("=> %s: largest recovered impulse %.2f N s\n", s.label().c_str(), r.bracket.max_recovered);
    std::fflush(stdout);
  };
  events.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  try {
    make_local_executor(jobs, store, /*resume=*/true, events)->run(mine);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_task: %s\n", e.what());
    return 1;
  }
  return 0;
}
