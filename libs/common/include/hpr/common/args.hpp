#pragma once
/// \file A tool's command line, one argument at a time, with strict values:
///
///   ArgReader args(argc, argv);
///   while (args.next()) {
///     if (args.is("--impulse")) impulse = args.number();
///     else if (args.is("--set")) overrides.push_back(args.value());
///     else if (args.positional()) log = args.current();
///     else args.unknown();
///   }
///
/// Every error is a UsageError (a std::invalid_argument) that names the option and the value.

#include <cstdio>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace hpr {

/// A malformed command line: the tool prints it with its usage.
class UsageError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class ArgReader {
 public:
  /// The arguments argv[first..argc).
  ArgReader(int argc, char** argv, int first = 1);
  explicit ArgReader(std::vector<std::string> args);

  /// Advances to the next argument; false after the last.
  bool next();
  [[nodiscard]] const std::string& current() const { return args_[i_]; }
  /// The current argument is `option` (which is remembered for unknown()'s suggestion).
  [[nodiscard]] bool is(std::string_view option) const;
  [[nodiscard]] bool is(std::string_view option, std::string_view alias) const { return is(option) || is(alias); }
  /// The current argument is not an option (does not start with '-', or is "-" itself).
  [[nodiscard]] bool positional() const;

  /// The current option's value (the next argument).
  std::string value();
  /// The value as a finite number: "1.5", "-3", "2e-3"; "12abc", "", "nan" are refused.
  double number();
  /// The value as an integer: "8", "-2"; "8.5", "8x" are refused.
  int integer();
  /// The value as a comma-separated list ("a,b,,c" gives a, b, c).
  std::vector<std::string> list();

  /// Throws "unknown option X (did you mean Y?)" for an option, "unexpected argument X" for
  /// anything else; Y is the nearest option is() was asked about.
  [[noreturn]] void unknown() const;

 private:
  std::vector<std::string> args_;
  mutable std::vector<std::string> options_;  ///< every option is() was asked about
  std::size_t i_ = static_cast<std::size_t>(-1);
};

/// A tool's whole command line: `-h` or `--help` prints `usage` on stdout (exit status 0); every
/// other argument goes to `each`, which reads it or calls args.unknown(); then `check` (may be
/// empty) checks the combination. An exception from either prints "<tool>: <what>" and the usage
/// on stderr (exit status 2). Returns nullopt when the command line is good, else the exit status.
std::optional<int> read_command_line(int argc, char** argv, const char* tool, const std::function<void(std::FILE*)>& usage,
                                     const std::function<void(ArgReader&)>& each, const std::function<void()>& check = {});

/// `text` as a finite number, else UsageError "<what>: '<text>' is not a finite number".
double parse_number(const std::string& text, const std::string& what);
/// `text` as an int, else UsageError "<what>: '<text>' is not an integer".
int parse_integer(const std::string& text, const std::string& what);
/// Splits "a,b,,c" at commas into a, b, c.
std::vector<std::string> split_list(const std::string& text, char separator = ',');

}  // namespace hpr
