// The log's rate limit: a call site that repeats writes kBurst lines a second, counts the rest and
// says how many with the last of them; other call sites are not held back.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <string>

#include "hpr/common/log.hpp"

namespace {

/// Captures what the process writes to stderr while it lives.
class StderrCapture {
 public:
  StderrCapture() {
    std::fflush(stderr);
    file_ = std::tmpfile();
    saved_ = ::dup(STDERR_FILENO);
    ::dup2(::fileno(file_), STDERR_FILENO);
  }
  ~StderrCapture() { restore(); }
  std::string text() {
    restore();
    std::rewind(file_);
    std::string out;
    char buf[4096];
    std::size_t n = 0;
    while ((n = std::fread(buf, 1, sizeof(buf), file_)) > 0) out.append(buf, n);
    return out;
  }

 private:
  void restore() {
    if (saved_ < 0) return;
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    saved_ = -1;
  }
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

void stuck(int k) { hpr::log::warn("sample {} refused: time does not advance", k); }
void other(int k) { hpr::log::warn("another call site {}", k); }

TEST(Log, ARepeatingCallSiteIsHeldToItsBurstAndTheRestIsCountedAndSaid) {
  const long long before = hpr::log::suppressed();
  StderrCapture capture;
  for (int k = 0; k < 1100; ++k) stuck(k);
  other(1);
  other(2);
  hpr::log::flush_repeats();  // the second has not ended: nothing said yet
  hpr::log::flush_repeats(true);
  const std::string text = capture.text();
  EXPECT_EQ(count(text, "time does not advance"), hpr::log::kBurst + 1) << text;
  EXPECT_EQ(count(text, "another call site"), 2) << text;
  EXPECT_NE(text.find("sample 1099 refused: time does not advance (and 1094 more like this in the last second)"), std::string::npos)
      << text;
  EXPECT_EQ(hpr::log::suppressed() - before, 1100 - hpr::log::kBurst);
}

TEST(Log, AfterASecondTheCallSiteWritesAgain) {
  StderrCapture capture;
  for (int k = 0; k < 10; ++k) hpr::log::info("tick {} late", k);
  ::usleep(1'050'000);
  hpr::log::info("tick {} late", 99);
  const std::string text = capture.text();
  // 5 in the first second, the held ones said with the first line after it, then that line.
  EXPECT_NE(text.find("tick 9 late (and 4 more like this in the last second)"), std::string::npos) << text;
  EXPECT_NE(text.find("tick 99 late\n"), std::string::npos) << text;
  EXPECT_EQ(count(text, " late"), hpr::log::kBurst + 2) << text;
}

}  // namespace
