// The `lander` command line: dispatches to the subcommands registered in cmd_*.cpp.
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "command.h"
#include "lander/core/params_io.h"

namespace lander::cli {

std::vector<CommandInfo>& registry() {
  static std::vector<CommandInfo> r;
  return r;
}

ArgParser::ArgParser(const Args& args, std::vector<std::string> value_options,
                     std::vector<std::string> flag_options) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.rfind("--", 0) == 0) {
      const std::string name = a.substr(2);
      if (std::find(flag_options.begin(), flag_options.end(), name) != flag_options.end()) {
        flags_.push_back(name);
      } else if (std::find(value_options.begin(), value_options.end(), name) !=
                 value_options.end()) {
        if (i + 1 >= args.size()) throw UsageError("option " + a + " needs a value");
        values_.emplace_back(name, args[++i]);
      } else {
        throw UsageError("unknown option " + a);
      }
    } else {
      positional_.push_back(a);
    }
  }
}

bool ArgParser::flag(const std::string& name) const {
  return std::find(flags_.begin(), flags_.end(), name) != flags_.end();
}

bool ArgParser::has(const std::string& name) const {
  for (const auto& kv : values_) {
    if (kv.first == name) return true;
  }
  return false;
}

std::string ArgParser::value(const std::string& name, const std::string& fallback) const {
  for (const auto& kv : values_) {
    if (kv.first == name) return kv.second;
  }
  return fallback;
}

namespace {

// `--name value` read whole by `parse` (std::stoll or std::stod) and at least `min`;
// UsageError naming the option otherwise. `what` is what the value must be.
template <class T, class Parse>
T parse_option(const std::string& name, const std::string& v, T min, const char* what,
               Parse parse) {
  std::size_t used = 0;
  T x{};
  try {
    x = parse(v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != v.size() || !std::isfinite(static_cast<double>(x))) {
    throw UsageError("option --" + name + ": '" + v + "' is not " + what);
  }
  if (x < min) {
    throw UsageError("option --" + name + ": " + v + " must be >= " + std::to_string(min));
  }
  return x;
}

}  // namespace

long long ArgParser::integer(const std::string& name, long long fallback, long long min) const {
  if (!has(name)) return fallback;
  return parse_option<long long>(name, value(name), min, "a whole number",
                                 [](const std::string& v, std::size_t* used) {
                                   return std::stoll(v, used);
                                 });
}

double ArgParser::number(const std::string& name, double fallback, double min) const {
  if (!has(name)) return fallback;
  return parse_option<double>(name, value(name), min, "a number",
                              [](const std::string& v, std::size_t* used) {
                                return std::stod(v, used);
                              });
}

std::vector<double> ArgParser::numbers(const std::string& name, const std::vector<double>& fallback,
                                       double min) const {
  if (!has(name)) return fallback;
  const std::string v = value(name);
  std::vector<double> out;
  std::istringstream is(v);
  for (std::string item; std::getline(is, item, ',');) {
    out.push_back(parse_option<double>(name, item, min, "a number (give a comma-separated list)",
                                       [](const std::string& x, std::size_t* used) {
                                         return std::stod(x, used);
                                       }));
  }
  if (out.empty()) {
    throw UsageError("option --" + name + ": '" + v + "' is not a comma-separated list of numbers");
  }
  return out;
}

std::string ArgParser::choice(const std::string& name, const std::string& fallback,
                              const std::vector<std::string>& allowed) const {
  const std::string v = value(name, fallback);
  for (const std::string& a : allowed) {
    if (v == a) return v;
  }
  std::string list;
  for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw UsageError("--" + name + " must be one of " + list + " (got '" + v + "')");
}

namespace {
void print_help(std::ostream& out) {
  out << "usage: lander COMMAND [ARGS]\n\ncommands:\n";
  for (const auto& c : registry()) {
    if (c.kind == Kind::Command) out << "  " << c.name << "\n      " << c.summary << "\n";
  }
  out << "  bench NAME --json FILE\n      benchmarks:";
  for (const auto& c : registry()) {
    if (c.kind == Kind::Bench) out << " " << c.name;
  }
  out << "\n";
}
}  // namespace

// A process started by the campaign runner dies with it: LANDER_DIE_WITH_PARENT holds the
// runner's pid. A runner killed with SIGKILL then leaves no run writing into the campaign.
void die_with_parent() {
  const char* v = std::getenv("LANDER_DIE_WITH_PARENT");
  if (!v || !*v) return;
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (std::to_string(getppid()) != v) std::_Exit(kExitFailure);  // the parent is already gone
}

int main_impl(int argc, char** argv) {
  die_with_parent();
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    print_help(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? kExitBadInput : kExitOk;
  }
  std::string name = argv[1];
  Kind kind = Kind::Command;
  int first = 2;
  if (name == "bench") {
    if (argc < 3) {
      print_help(std::cerr);
      return kExitBadInput;
    }
    name = argv[2];
    kind = Kind::Bench;
    first = 3;
  }
  for (const auto& c : registry()) {
    if (c.name == name && c.kind == kind) {
      const Args args(argv + first, argv + argc);
      try {
        return c.run(args);
      } catch (const UsageError& e) {
        // `--help` among the arguments of a command that does not take it: its summary.
        if (std::find(args.begin(), args.end(), "--help") != args.end() ||
            std::find(args.begin(), args.end(), "-h") != args.end()) {
          std::cout << "lander " << (kind == Kind::Bench ? "bench " : "") << c.summary
                    << "\n(every option: docs/reference/cli.md)\n";
          return kExitOk;
        }
        std::cerr << "lander " << (kind == Kind::Bench ? "bench " : "") << name << ": " << e.what()
                  << "\n";
        return kExitBadInput;
      } catch (const ConfigError& e) {
        std::cerr << "lander: " << e.what() << "\n";
        return kExitBadInput;
      } catch (const std::exception& e) {
        std::cerr << "lander: error: " << e.what() << "\n";
        return kExitFailure;
      }
    }
  }
  std::cerr << "lander: unknown " << (kind == Kind::Bench ? "benchmark" : "command") << " '"
            << name << "'\n";
  print_help(std::cerr);
  return kExitBadInput;
}

}  // namespace lander::cli

int main(int argc, char** argv) { return lander::cli::main_impl(argc, argv); }
