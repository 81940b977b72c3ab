// `lander campaign run|report|slurm|plan`: Monte-Carlo campaigns (campaign/ library).
//
//   lander campaign run CAMPAIGN.yaml --out DIR [--jobs N] [--shard K/M] [--only ID,...]
//                       [--timeout-s S] [--retry-failed] [--no-report] [--no-progress]
//   lander campaign report DIR
//   lander campaign slurm CAMPAIGN.yaml --out DIR [--runs-per-task R] [--throttle T]
//                         [--cpus-per-task C] [--partition P] [--time-min MIN]
//   lander campaign plan CAMPAIGN.yaml           (the runs and their sampled values; no run)
#include <unistd.h>

#include <filesystem>

#include "lander/core/params_io.h"
#include <iostream>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "command.h"
#include "lander/campaign/campaign.h"
#include "lander/campaign/merge.h"
#include "lander/campaign/runner.h"
#include "lander/campaign/runner_lock.h"
#include "lander/campaign/slurm.h"

namespace lander::cli {
namespace {

namespace fs = std::filesystem;
using campaign::Campaign;

const char* kUsage =
    "usage:\n"
    "  lander campaign run CAMPAIGN.yaml --out DIR [--jobs N] [--shard K/M] [--only ID,...]\n"
    "                      [--timeout-s S] [--retry-failed] [--no-report] [--no-progress]\n"
    "                      [--flight-plugin LIB.so]\n"
    "  lander campaign report DIR\n"
    "  lander campaign slurm CAMPAIGN.yaml --out DIR [--runs-per-task R] [--throttle T]\n"
    "                        [--cpus-per-task C] [--partition P] [--time-min MIN]\n"
    "  lander campaign plan CAMPAIGN.yaml";

// "K/M" with 0 <= K < M.
std::pair<int, int> parse_shard(const std::string& v) {
  const auto slash = v.find('/');
  try {
    if (slash == std::string::npos) throw std::invalid_argument("");
    std::size_t a = 0, b = 0;
    const int k = std::stoi(v.substr(0, slash), &a);
    const int m = std::stoi(v.substr(slash + 1), &b);
    if (a != slash || b != v.size() - slash - 1 || m < 1 || k < 0 || k >= m) throw std::invalid_argument("");
    return {k, m};
  } catch (const std::exception&) {
    throw UsageError("option --shard: '" + v + "' is not K/M with 0 <= K < M (e.g. 0/4)");
  }
}

std::vector<std::string> split_commas(const std::string& v) {
  std::vector<std::string> out;
  std::stringstream ss(v);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

}  // namespace

// Prints the merged figures a person looks at first (also used by `lander batch`).
void print_campaign_merge(const campaign::MergeResult& m, const std::string& dir) {
  const auto& o = m.campaign["overall"];
  const auto& lr = o["landing_rate"];
  std::cout << fmt::format("lander campaign: {}: {} of {} runs complete", m.campaign["name"].get<std::string>(),
                           m.complete, m.planned);
  if (!m.missing.empty()) std::cout << fmt::format(" ({} missing)", m.missing.size());
  std::cout << "\n";
  if (!lr["value"].is_null()) {
    std::cout << fmt::format("  landed {} of {} ({:.1f} %, 95 % interval {:.1f}-{:.1f} %)",
                             o["landed"].get<int>(), lr["of_runs"].get<int>(),
                             100 * lr["value"].get<double>(), 100 * lr["ci95"][0].get<double>(),
                             100 * lr["ci95"][1].get<double>());
    const auto& off = o["touchdown_offset_m"];
    if (!off["median"].is_null()) {
      std::cout << fmt::format("; touchdown offset median {:.1f} cm, p95 {:.1f} cm, max {:.1f} cm",
                               100 * off["median"].get<double>(), 100 * off["p95"].get<double>(),
                               100 * off["max"].get<double>());
    }
    std::cout << "\n";
  }
  if (o.contains("path_following")) {
    // Route campaigns (seed 003): covered and ended routes, the runs' mean cross-track errors.
    const auto& pf = o["path_following"];
    const auto& xt = pf["cross_track_mean_m"];
    std::cout << fmt::format("  path following: {} of {} runs covered their route, {} ended at it",
                             pf["covered"].get<int>(), pf["runs"].get<int>(), pf["route_end"].get<int>());
    if (!xt["mean"].is_null()) {
      std::cout << fmt::format("; cross-track mean {:.1f} cm over the runs (worst run {:.1f} cm)",
                               100 * xt["mean"].get<double>(), 100 * xt["max"].get<double>());
    }
    std::cout << "\n";
  }
  std::cout << fmt::format("  simulator failures: {}\n", m.simulator_failures);
  std::cout << "  outputs: " << dir << "/campaign.json, " << dir << "/campaign.csv";
  if (m.html_written) std::cout << ", " << dir << "/report.html";
  std::cout << "\n";
  if (!m.html_error.empty()) std::cerr << "lander campaign: report.html not written: " << m.html_error << "\n";
}

namespace {

int cmd_run(const Args& rest) {
  ArgParser a(rest, {"out", "jobs", "shard", "only", "timeout-s", "flight-plugin"},
              {"retry-failed", "no-report", "no-progress"});
  if (a.positional().size() != 1 || !a.has("out")) throw UsageError(kUsage);
  campaign::RunnerOptions o;
  o.out_dir = a.value("out");
  const long long cores = std::max(1u, std::thread::hardware_concurrency());
  o.jobs = static_cast<int>(a.integer("jobs", cores, 1));
  if (a.has("shard")) std::tie(o.shard_index, o.shard_count) = parse_shard(a.value("shard"));
  if (a.has("only")) o.only = split_commas(a.value("only"));
  o.timeout_s = a.number("timeout-s", 0.0, 0.0);
  o.retry_failed = a.flag("retry-failed");
  o.progress = !a.flag("no-progress");
  // Everything is checked before the first run starts.
  Campaign c = Campaign::load(a.positional()[0]);
  // --flight-plugin: every run flies this plugin (the campaign file's flight_plugin replaced).
  if (a.has("flight-plugin")) {
    c.flight_plugin = fs::absolute(a.value("flight-plugin")).lexically_normal().string();
    if (!fs::is_regular_file(c.flight_plugin)) throw ConfigError("--flight-plugin: no such file: " + c.flight_plugin);
  }
  const auto plan = campaign::make_plan(c);
  // One runner per directory and shard: a second one stops here, before it writes anything
  // (campaign/runner_lock.h). Held until this command returns.
  const campaign::RunnerLock lock = campaign::RunnerLock::acquire(o);
  if (!lock.note().empty()) std::cerr << "lander campaign: " << lock.note() << "\n";
  campaign::write_plan(c, plan, o.out_dir);
  const campaign::RunnerResult r = campaign::run_campaign(c, plan, o);
  if (r.interrupted) {
    std::cerr << "lander campaign: interrupted; run the same command again to resume\n";
    return 130;
  }
  if (a.flag("no-report")) return r.simulator_failures > 0 ? kExitFailure : kExitOk;
  const campaign::MergeResult m = campaign::merge_campaign(o.out_dir);
  print_campaign_merge(m, o.out_dir);
  return (m.simulator_failures > 0 || !m.html_written) ? kExitFailure : kExitOk;
}

int cmd_report(const Args& rest) {
  ArgParser a(rest, {}, {"no-html"});
  if (a.positional().size() != 1) throw UsageError(kUsage);
  campaign::MergeOptions mo;
  mo.html = !a.flag("no-html");
  const campaign::MergeResult m = campaign::merge_campaign(a.positional()[0], mo);
  print_campaign_merge(m, a.positional()[0]);
  return (m.simulator_failures > 0 || (mo.html && !m.html_written)) ? kExitFailure : kExitOk;
}

int cmd_slurm(const Args& rest) {
  ArgParser a(rest, {"out", "runs-per-task", "throttle", "cpus-per-task", "partition", "time-min"}, {});
  if (a.positional().size() != 1 || !a.has("out")) throw UsageError(kUsage);
  campaign::SlurmOptions o;
  o.out_dir = a.value("out");
  o.runs_per_task = static_cast<int>(a.integer("runs-per-task", 4, 1));
  o.throttle = static_cast<int>(a.integer("throttle", 0, 0));
  o.cpus_per_task = static_cast<int>(a.integer("cpus-per-task", 1, 1));
  o.partition = a.value("partition");
  o.time_limit_min = a.number("time-min", 0.0, 0.0);
  const Campaign c = Campaign::load(a.positional()[0]);
  const auto plan = campaign::make_plan(c);
  const campaign::SlurmFiles f = campaign::write_slurm_files(c, plan, o);
  std::cout << fmt::format(
      "lander campaign slurm: {} runs in {} array tasks\n"
      "  submit:            sbatch {}\n"
      "  or GNU parallel:   parallel -j N < {}\n"
      "  then merge:        lander campaign report {}\n",
      plan.size(), f.array_tasks, f.sbatch_path, f.joblist_path, o.out_dir);
  return kExitOk;
}

int cmd_plan(const Args& rest) {
  ArgParser a(rest, {}, {});
  if (a.positional().size() != 1) throw UsageError(kUsage);
  const Campaign c = Campaign::load(a.positional()[0]);
  const auto plan = campaign::make_plan(c);
  std::cout << fmt::format("campaign {}: master seed {}, {} runs\n", c.name, c.seed, plan.size());
  for (const auto& r : plan) {
    std::cout << r.id << "  seed " << r.seed;
    for (const auto& [k, v] : r.sampled) {
      for (const auto& [col, text] : campaign::flatten_value(k, v)) std::cout << "  " << col << "=" << text;
    }
    std::cout << "\n";
  }
  return kExitOk;
}

int campaign_cmd(const Args& args) {
  if (args.empty()) throw UsageError(kUsage);
  const std::string sub = args[0];
  const Args rest(args.begin() + 1, args.end());
  if (sub == "run") return cmd_run(rest);
  if (sub == "report") return cmd_report(rest);
  if (sub == "slurm") return cmd_slurm(rest);
  if (sub == "plan") return cmd_plan(rest);
  if (sub == "--help" || sub == "-h") {
    std::cout << kUsage << "\n";
    return kExitOk;
  }
  throw UsageError("unknown campaign command '" + sub + "'\n" + kUsage);
}

const LanderCommand reg("campaign",
                        "campaign run|report|slurm|plan ...: Monte-Carlo campaigns (dispersions, "
                        "parallel resumable runs, statistics, report.html, Slurm)",
                        Kind::Command, campaign_cmd);

}  // namespace
}  // namespace lander::cli
