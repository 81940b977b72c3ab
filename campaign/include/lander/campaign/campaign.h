// A Monte-Carlo campaign (campaigns/*.yaml): scenario files, runs per scenario, a master seed
// and dispersions (any scenario key, by its dotted path, gets a distribution).
//
//   name: smoke
//   seed: 1                                   # master seed
//   offset_limit_m: 0.10                      # drawn in the report; optional
//   run_timeout_s: 900                        # wall-clock limit of one run; optional
//   scenarios:                                # paths relative to this file
//     - {file: ../scenarios/default.yaml, runs: 4}
//     - {file: ../scenarios/cart_1mps_turning.yaml, runs: 2, dispersions: {...}}
//     - {file: ../scenarios/static_platform.yaml, runs: 5, first_seed: 100}  # seeds 100..104
//   dispersions:                              # applied to every scenario listed
//     cart.speed_mps: {uniform: [0.0, 1.5]}
//     cart.path: {choice: [straight, arc]}
//     vehicle.start_m: {normal: {mean: [-5, 0, 10], std: [3, 3, 2]}, min: [-12, -8, 6], max: [2, 8, 15]}
//
// Run i of a scenario gets the seed derive(master seed, scenario id, i); each dispersion draws
// from its own stream derive(run seed, key), so the sampled values depend only on (master
// seed, scenario, i, key): not on the number of workers, their order, the machine, or which
// other keys are dispersed. Every run's scenario is checked by the scenario's own validate()
// before any run starts; errors name the campaign file, line and key.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace lander::campaign {

// One dispersed key: a distribution read from YAML (see distribution kinds in campaign.cpp:
// uniform, normal (truncated with min/max), loguniform, integer, choice (with weights),
// polar, constant), scalar or per component of a vector key.
struct Dispersion {
  std::string key;    ///< dotted scenario key, e.g. "cart.speed_mps"
  std::string where;  ///< "file:line" of the key in the campaign file
  YAML::Node spec;    ///< the distribution mapping
  // Draws one value for a key whose default value is `like` (a scalar or a sequence of n).
  // `stream_seed` is the dispersion's own random stream. Throws ConfigError naming `where`.
  YAML::Node sample(std::uint64_t stream_seed, const YAML::Node& like) const;
};

struct ScenarioEntry {
  std::string file;   ///< scenario path as resolved against the campaign file's folder
  std::string id;     ///< run ids are "<id>-<i>" (default: the file's stem)
  int runs{1};
  long long first_seed{-1};  ///< >= 0: run i takes the seed first_seed + i (`lander batch`)
  std::vector<Dispersion> dispersions;  ///< entry dispersions (override campaign ones per key)
  std::string where;  ///< "file:line" of the entry
};

struct Campaign {
  std::string file;                  ///< the campaign file as given
  std::string name{"campaign"};
  std::uint64_t seed{1};             ///< master seed
  double offset_limit_m{0.10};       ///< touchdown offset limit drawn in the report (m)
  double run_timeout_s{0.0};         ///< wall-clock limit of one run (s); 0: 120 s + 20 x duration
  /// The flight plugin every run flies (absolute path; empty: each scenario's flight.plugin,
  /// by default ours built in). The campaign key `flight_plugin:` (relative to the campaign
  /// file) or `lander campaign run --flight-plugin LIB.so` sets it: the same campaign flown
  /// by two flight softwares gives paired runs for `lander regress`.
  std::string flight_plugin;
  std::vector<ScenarioEntry> scenarios;
  std::vector<Dispersion> dispersions;

  // Reads and checks a campaign file (unknown keys, impossible distributions, unknown
  // scenario keys). Throws ConfigError with file:line and key.
  static Campaign load(const std::string& path);
};

// One run of the plan.
struct PlannedRun {
  std::string id;               ///< "<scenario id>-<i>", 4 digits
  std::string scenario;         ///< the scenario entry's id
  std::string scenario_file;
  int index{0};                 ///< i within its scenario
  int plan_index{0};            ///< position in the whole plan (shards split on it)
  std::uint64_t seed{0};        ///< the run's scenario seed
  std::vector<std::pair<std::string, YAML::Node>> sampled;  ///< key -> value in force
  double duration_s{0.0};
  std::string flight_plugin;    ///< Campaign::flight_plugin
};

// Samples every run and checks each one's scenario with validate(). Throws ConfigError naming
// the campaign file, line and key of the dispersion (or entry) that produced a bad value.
// The plan holds each run's sampled values, not its scenario text (15 kB a run: a
// 100000-run plan would hold 1.5 GB, and writing the text twice to reach its fixed point
// cost 28 ms a run, 47 min for 100000 runs before the first started).
std::vector<PlannedRun> make_plan(const Campaign& c);

// The run's whole scenario, resolved: its scenario file with the sampled values and the
// run's seed in force, written to its fixed point so that loading it back and writing it
// again gives the same bytes. Made when the run starts (reads the scenario file again).
std::string run_scenario_yaml(const PlannedRun& r);

// The run's seed: a function of the master seed, the scenario id and the run index only.
std::uint64_t run_seed(std::uint64_t master_seed, const std::string& scenario_id, int index);

// Flattens a sampled value into named columns: "key" for a scalar, "key[0]".. for a list.
std::vector<std::pair<std::string, std::string>> flatten_value(const std::string& key,
                                                               const YAML::Node& v);

}  // namespace lander::campaign
