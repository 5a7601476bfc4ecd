#include "hpr/common/args.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include "hpr/common/text.hpp"

namespace hpr {

ArgReader::ArgReader(int argc, char** argv, int first) {
  for (int k = first; k < argc; ++k) args_.emplace_back(argv[k]);
}

ArgReader::ArgReader(std::vector<std::string> args) : args_(std::move(args)) {}

bool ArgReader::next() {
  ++i_;
  return i_ < args_.size();
}

bool ArgReader::positional() const { return current().empty() || current()[0] != '-' || current() == "-"; }

std::string ArgReader::value() {
  const std::string option = current();
  if (i_ + 1 >= args_.size()) throw UsageError(option + " needs a value");
  return args_[++i_];
}

double ArgReader::number() {
  const std::string option = current();
  return parse_number(value(), option);
}

int ArgReader::integer() {
  const std::string option = current();
  return parse_integer(value(), option);
}

std::vector<std::string> ArgReader::list() { return split_list(value()); }

bool ArgReader::is(std::string_view option) const {
  if (std::find(options_.begin(), options_.end(), option) == options_.end()) options_.emplace_back(option);
  return current() == option;
}

void ArgReader::unknown() const {
  if (positional()) throw UsageError("unexpected argument '" + current() + "'");
  const std::string name = current().substr(0, current().find('='));
  throw UsageError("unknown option " + current() + did_you_mean(name, options_));
}

double parse_number(const std::string& text, const std::string& what) {
  char* end = nullptr;
  errno = 0;
  const double d = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(d)) {
    throw UsageError(what + ": '" + text + "' is not a finite number");
  }
  return d;
}

int parse_integer(const std::string& text, const std::string& what) {
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || n < std::numeric_limits<int>::min() ||
      n > std::numeric_limits<int>::max()) {
    throw UsageError(what + ": '" + text + "' is not an integer");
  }
  return static_cast<int>(n);
}

std::vector<std::string> split_list(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::size_t s = 0;
  while (s <= text.size()) {
    const std::size_t e = std::min(text.find(separator, s), text.size());
    if (e > s) out.push_back(text.substr(s, e - s));
    s = e + 1;
  }
  return out;
}

std::optional<int> read_command_line(int argc, char** argv, const char* tool, const std::function<void(std::FILE*)>& usage,
                                     const std::function<void(ArgReader&)>& each, const std::function<void()>& check) {
  try {
    ArgReader args(argc, argv);
    while (args.next()) {
      if (args.is("-h", "--help")) {
        usage(stdout);
        return 0;
      }
      each(args);
    }
    if (check) check();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", tool, e.what());
    usage(stderr);
    return 2;
  }
  return std::nullopt;
}

}  // namespace hpr
