// `lander batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR [--jobs J]`: a shorthand
// for a campaign of one scenario without dispersions whose runs take the seeds S .. S+N-1
// (S defaults to the scenario's seed). It writes DIR/batch.campaign.yaml and runs it with
// the campaign machinery: runs in DIR/runs/<scenario>-<i>/, DIR/campaign.csv,
// DIR/campaign.json, DIR/report.html; resumable like any campaign.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include <yaml-cpp/yaml.h>

#include "command.h"
#include "lander/campaign/campaign.h"
#include "lander/campaign/merge.h"
#include "lander/campaign/runner.h"
#include "lander/campaign/runner_lock.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/scenario.h"

namespace lander::cli {

// Defined in cmd_campaign.cpp.
void print_campaign_merge(const campaign::MergeResult& m, const std::string& dir);

namespace {

namespace fs = std::filesystem;

int batch(const Args& args) {
  ArgParser a(args, {"out", "seeds", "first-seed", "jobs"}, {});
  const char* usage = "usage: lander batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR [--jobs J]";
  if (a.positional().size() != 1) throw UsageError(usage);
  if (!a.has("out")) throw UsageError(std::string("missing --out DIR\n") + usage);
  if (!a.has("seeds")) throw UsageError(std::string("missing --seeds N\n") + usage);
  const long long n = a.integer("seeds", 0, 1);
  const std::string scenario = fs::absolute(a.positional()[0]).lexically_normal().string();
  const sim::Scenario s = sim::Scenario::load(scenario);
  const long long first = a.integer("first-seed", static_cast<long long>(s.seed), 0);
  if (s.vehicle.control != "closed_loop") {
    throw UsageError(a.positional()[0] + ": vehicle.control is '" + s.vehicle.control +
                     "'; landing statistics need a closed_loop scenario");
  }
  const long long cores = std::max(1u, std::thread::hardware_concurrency());
  campaign::RunnerOptions o;
  o.out_dir = a.value("out");
  o.jobs = static_cast<int>(a.integer("jobs", cores, 1));
  // The campaign this batch is: one entry, explicit seeds.
  YAML::Node c(YAML::NodeType::Map);
  c["name"] = "batch-" + s.name;
  c["seed"] = 0;
  YAML::Node entry(YAML::NodeType::Map);
  entry["file"] = scenario;
  entry["runs"] = n;
  entry["first_seed"] = first;
  c["scenarios"].push_back(entry);
  fs::create_directories(o.out_dir);
  const std::string file = o.out_dir + "/batch.campaign.yaml";
  sim::write_file_atomic(file, YAML::Dump(c) + "\n");
  const campaign::Campaign camp = campaign::Campaign::load(file);
  const auto plan = campaign::make_plan(camp);
  // One runner per directory, as for `lander campaign run` (campaign/runner_lock.h).
  const campaign::RunnerLock lock = campaign::RunnerLock::acquire(o);
  if (!lock.note().empty()) std::cerr << "lander batch: " << lock.note() << "\n";
  campaign::write_plan(camp, plan, o.out_dir);
  const campaign::RunnerResult r = campaign::run_campaign(camp, plan, o);
  if (r.interrupted) return 130;
  const campaign::MergeResult m = campaign::merge_campaign(o.out_dir);
  print_campaign_merge(m, o.out_dir);
  return (m.simulator_failures > 0 || !m.html_written) ? kExitFailure : kExitOk;
}

const LanderCommand reg("batch",
                        "batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR [--jobs J]: "
                        "shorthand for a campaign of one scenario over seeds S..S+N-1",
                        Kind::Command, batch);

}  // namespace
}  // namespace lander::cli
