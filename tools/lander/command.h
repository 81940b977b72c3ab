// Subcommand registry of the `lander` tool. Each tools/lander/cmd_*.cpp registers its
// commands with a static LanderCommand object; main.cpp dispatches. `lander bench NAME`
// dispatches to the benches registered with kind Bench.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace lander::cli {

using Args = std::vector<std::string>;  // arguments after the command name
using CommandFn = std::function<int(const Args&)>;

enum class Kind { Command, Bench };

struct CommandInfo {
  std::string name;
  std::string summary;  // one line for `lander --help`
  Kind kind;
  CommandFn run;
};

std::vector<CommandInfo>& registry();

struct LanderCommand {
  LanderCommand(std::string name, std::string summary, Kind kind, CommandFn fn) {
    registry().push_back({std::move(name), std::move(summary), kind, std::move(fn)});
  }
};

// Exit codes: 0 success, 1 runtime failure (e.g. a run that diverged), 2 bad input/usage.
constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

// Small argument helpers: `--key value` options and flags. Unknown options are an error.
class ArgParser {
 public:
  ArgParser(const Args& args, std::vector<std::string> value_options,
            std::vector<std::string> flag_options);
  const std::vector<std::string>& positional() const { return positional_; }
  bool flag(const std::string& name) const;
  std::string value(const std::string& name, const std::string& fallback = "") const;
  bool has(const std::string& name) const;
  // `--name` as a whole number >= min (fallback when absent); UsageError naming the option
  // when it is not one ("--seeds abc", "--seeds 1.5", "--seeds -2").
  long long integer(const std::string& name, long long fallback, long long min) const;
  // `--name` as a finite number >= min (fallback when absent); UsageError naming the option.
  double number(const std::string& name, double fallback, double min) const;
  // `--name A,B,...` as finite numbers, each >= min (fallback when absent); UsageError naming
  // the option for an empty list or item.
  std::vector<double> numbers(const std::string& name, const std::vector<double>& fallback,
                              double min) const;
  // The option's value (fallback when absent), which must be one of `allowed` (UsageError).
  std::string choice(const std::string& name, const std::string& fallback,
                     const std::vector<std::string>& allowed) const;

 private:
  std::vector<std::string> positional_;
  std::vector<std::pair<std::string, std::string>> values_;
  std::vector<std::string> flags_;
};

// Thrown for usage errors; main prints it and exits with kExitBadInput.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace lander::cli
