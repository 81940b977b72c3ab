// `lander regress`: the statistical regression gate between two campaigns (campaign/regress.h).
//
//   lander regress CURRENT_DIR --baseline BASELINE_DIR [--thresholds FILE] [--json FILE] [--html
//   FILE] lander regress --accept CURRENT_DIR --baseline BASELINE_DIR
//
// The first compares the merged campaign in CURRENT_DIR with the baseline, writes
// CURRENT_DIR/regress.json (and FILE), prints a summary, and exits 1 when a threshold of
// BASELINE_DIR/thresholds.yaml is crossed with confidence, 0 otherwise, 2 on bad input. The
// second makes CURRENT_DIR the baseline (its merged results, not its runs).
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "command.h"
#include "lander/campaign/regress.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"

namespace lander::cli {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

const char* kUsage =
    "usage:\n"
    "  lander regress CURRENT_DIR --baseline BASELINE_DIR [--thresholds FILE] [--json FILE] "
    "[--html FILE]\n"
    "  lander regress --accept CURRENT_DIR --baseline BASELINE_DIR";

// Runs listed on stdout per kind (all of them are in regress.json).
constexpr std::size_t kListedRuns = 20;

// "2.51" for a number, "-" for null; value * scale with `digits` decimals.
std::string show(const json& v, double scale, int digits, bool sign = false) {
  if (!v.is_number()) return "-";
  return sign ? fmt::format("{:+.{}f}", v.get<double>() * scale, digits)
              : fmt::format("{:.{}f}", v.get<double>() * scale, digits);
}

std::string show_ci(const json& ci, double scale, int digits) {
  if (!ci.is_array()) return "[no interval]";
  return fmt::format("[{}, {}]", show(ci.at(0), scale, digits, true),
                     show(ci.at(1), scale, digits, true));
}

// "baseline -> current unit  difference unit [interval]" of a {baseline, current, difference,
// ci95}.
std::string show_change(const json& s, double scale, int digits, const char* unit) {
  return fmt::format("{} -> {} {}  {} {} {}", show(s.at("baseline"), scale, digits),
                     show(s.at("current"), scale, digits), unit,
                     show(s.at("difference"), scale, digits, true), unit,
                     show_ci(s.at("ci95"), scale, digits));
}

// A run's detail on one line.
std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  return s;
}

void print_group(const std::string& name, const json& g) {
  const json& lr = g.at("landing_rate");
  std::cout << fmt::format("  {} ({} paired runs):\n", name, g.at("runs").get<int>());
  std::cout << fmt::format(
      "    landing rate              {} -> {} %  {} points {}   ({} pairs completed by the "
      "simulator)\n",
      show(lr.at("baseline"), 100, 1), show(lr.at("current"), 100, 1),
      show(lr.at("difference"), 100, 2, true), show_ci(lr.at("ci95"), 100, 2),
      lr.at("pairs").get<int>());
  const json& off = g.at("touchdown_offset_m");
  std::cout << fmt::format("    offset median             {}   ({} landed in both)\n",
                           show_change(off.at("median"), 100, 2, "cm"), off.at("n").get<int>());
  std::cout << fmt::format("    offset p95                {}\n",
                           show_change(off.at("p95"), 100, 2, "cm"));
  std::cout << fmt::format("    rel. speed median         {}\n",
                           show_change(g.at("touchdown_rel_speed_mps").at("median"), 1, 3, "m/s"));
  std::cout << fmt::format("    time to land median       {}\n",
                           show_change(g.at("time_to_land_s").at("median"), 1, 2, "s"));
  std::cout << fmt::format(
      "    landed -> not landed: {}; not landed -> landed: {}; simulator failures: {} -> {}\n",
      g.at("landed_to_not_landed").get<int>(), g.at("not_landed_to_landed").get<int>(),
      g.at("simulator_failures").at("baseline").get<int>(),
      g.at("simulator_failures").at("current").get<int>());
}

void print_checks(const json& checks) {
  std::cout << "checks (a check fails only when crossed with confidence):\n";
  for (const json& c : checks) {
    const std::string st = c.at("status").get<std::string>();
    std::cout << fmt::format("  {:<5} {:<29} {}\n",
                             st == "fail"   ? "FAIL"
                             : st == "pass" ? "pass"
                                            : "n/a",
                             c.at("check").get<std::string>(), c.at("message").get<std::string>());
    if (st == "fail") std::cout << "        reason: " << c.at("reason").get<std::string>() << "\n";
  }
}

void print_runs(const char* title, const json& runs) {
  std::cout << fmt::format("{} ({}):\n", title, runs.size());
  for (std::size_t i = 0; i < runs.size() && i < kListedRuns; ++i) {
    const json& t = runs[i];
    std::cout << fmt::format(
        "  {} ({}): {} -> {}\n    rerun: {}\n", t.at("id").get<std::string>(),
        t.at("scenario").get<std::string>(), t.at("baseline").at("outcome").get<std::string>(),
        t.at("current").at("outcome").get<std::string>(), t.at("rerun").get<std::string>());
  }
  if (runs.size() > kListedRuns)
    std::cout << fmt::format("  ... {} more in regress.json\n", runs.size() - kListedRuns);
}

void print_simulator_failures(const json& f) {
  const json& runs = f.at("current_runs");
  std::cout << fmt::format(
      "simulator failures: {} in the baseline, {} in the current campaign (paired runs)\n",
      f.at("paired_baseline").get<int>(), f.at("paired_current").get<int>());
  for (std::size_t i = 0; i < runs.size() && i < kListedRuns; ++i) {
    const json& r = runs[i];
    std::cout << fmt::format("  {} ({}): {} {}\n    rerun: {}\n", r.at("id").get<std::string>(),
                             r.at("scenario").get<std::string>(), r.at("status").get<std::string>(),
                             one_line(r.at("detail").get<std::string>()),
                             r.at("rerun").get<std::string>());
  }
}

// The human summary of regress.json.
void print_summary(const json& r) {
  const json& cur = r.at("current");
  const json& base = r.at("baseline");
  const json& p = r.at("pairing");
  std::cout << fmt::format("lander regress: {} ({} runs) against the baseline {} ({} runs)\n",
                           cur.at("dir").get<std::string>(), cur.at("runs").get<int>(),
                           base.at("dir").get<std::string>(), base.at("runs").get<int>());
  std::cout << fmt::format("  flight software: {} (current), {} (baseline)\n",
                           cur.at("flight_software").get<std::string>(), base.at("flight_software").get<std::string>());
  std::cout << fmt::format("  thresholds: {}\n", r.at("thresholds").at("file").get<std::string>());
  std::cout << fmt::format(
      "  paired runs: {}; left out: {} only in the current campaign, {} only in the baseline\n",
      p.at("paired").get<int>(), p.at("only_in_current").size(), p.at("only_in_baseline").size());
  print_group("overall", r.at("overall"));
  if (r.at("scenarios").size() > 1) {
    for (const auto& [name, g] : r.at("scenarios").items()) print_group(name, g);
  }
  print_checks(r.at("checks"));
  print_runs("runs that stopped landing", r.at("transitions").at("landed_to_not_landed"));
  print_runs("runs that started landing", r.at("transitions").at("not_landed_to_landed"));
  print_simulator_failures(r.at("simulator_failures"));
  const json& failed = r.at("failed_checks");
  if (failed.empty()) {
    std::cout << "gate: PASS (no threshold crossed with confidence)\n";
  } else {
    std::vector<std::string> names = failed.get<std::vector<std::string>>();
    std::cout << fmt::format("gate: FAIL: {} check(s) crossed with confidence: {}\n", names.size(),
                             fmt::join(names, "; "));
  }
}

// report.html-style page of the comparison through tools/regress_report.py; "" when written,
// else why not.
std::string write_html(const std::string& json_path, const std::string& html_path) {
  const std::string script = std::string(LANDER_TOOLS_DIR) + "/regress_report.py";
  try {
    sim::SpawnOptions so;
    so.stdout_to_null = true;
    sim::ChildProcess p = sim::ChildProcess::spawn({"python3", script, json_path, html_path}, so);
    const sim::ExitStatus st = p.wait();
    return st.ok() ? "" : script + " failed (" + st.describe() + ")";
  } catch (const std::exception& e) {
    return e.what();
  }
}

int cmd_accept(const ArgParser& a) {
  const campaign::AcceptResult r =
      campaign::accept_baseline(a.positional()[0], a.value("baseline"));
  std::cout << fmt::format("lander regress --accept: {} is now the baseline in {}\n",
                           a.positional()[0], a.value("baseline"));
  for (const std::string& f : r.copied) std::cout << "  wrote " << f << "\n";
  std::cout << (r.thresholds_written ? "  wrote the default " : "  kept ") << r.thresholds_path
            << "\n"
            << "  review and commit the diff of the baseline directory\n";
  return kExitOk;
}

int cmd_compare(const ArgParser& a) {
  const std::string dir = a.positional()[0];
  campaign::RegressOptions o;
  o.thresholds_path = a.value("thresholds");
  const campaign::RegressResult r = campaign::regress(dir, a.value("baseline"), o);
  std::vector<std::string> outputs = {dir + "/regress.json"};
  if (a.has("json")) outputs.push_back(a.value("json"));
  for (const std::string& path : outputs) sim::write_json_file(path, r.report);
  print_summary(r.report);
  std::string html_error;
  if (a.has("html")) {
    html_error = write_html(outputs[0], a.value("html"));
    if (html_error.empty()) outputs.push_back(a.value("html"));
  }
  std::cout << "outputs: " << fmt::format("{}", fmt::join(outputs, ", ")) << "\n";
  if (!html_error.empty()) {
    std::cerr << "lander regress: " << a.value("html") << " not written: " << html_error << "\n";
    return kExitFailure;
  }
  return r.failed() ? kExitFailure : kExitOk;
}

int regress_cmd(const Args& args) {
  ArgParser a(args, {"baseline", "thresholds", "json", "html"}, {"accept", "help"});
  if (a.flag("help")) {
    std::cout << kUsage << "\n";
    return kExitOk;
  }
  if (a.positional().size() != 1 || !a.has("baseline")) throw UsageError(kUsage);
  if (a.flag("accept")) {
    if (a.has("thresholds") || a.has("json") || a.has("html")) {
      throw UsageError("--accept takes only CURRENT_DIR and --baseline\n" + std::string(kUsage));
    }
    return cmd_accept(a);
  }
  return cmd_compare(a);
}

const LanderCommand reg(
    "regress",
    "regress CURRENT_DIR --baseline DIR [--json F] [--html F] | --accept CURRENT_DIR "
    "--baseline DIR: statistical regression gate between two campaigns",
    Kind::Command, regress_cmd);

}  // namespace
}  // namespace lander::cli
