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
#include <variant>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace lander::campaign {

// The distributions a dispersion can give (campaign.cpp lists their YAML forms), parsed and
// checked once when the campaign is loaded, so that drawing from them only draws (as Drake's
// schema::Stochastic does). Vectors hold one entry per component of the dispersed key (one
// for a scalar key).
struct UniformDistribution {
  std::vector<double> lo, hi;  ///< lo <= hi
};
struct LogUniformDistribution {
  std::vector<double> lo, hi;  ///< 0 < lo <= hi; uniform in log
};
struct IntegerDistribution {
  std::vector<double> lo, hi;  ///< whole numbers, lo <= hi, both ends included
};
struct NormalDistribution {
  std::vector<double> mean, std;  ///< std >= 0
  std::vector<double> min, max;   ///< truncation (+-infinity when absent), min <= max
};
// `choice` (and `constant`, a choice of one): YAML values of the key's shape.
struct ChoiceDistribution {
  std::vector<YAML::Node> options;
  std::vector<double> weights;  ///< >= 0, one per option (1 each when not given)
  double total_weight{0.0};     ///< > 0
};
// A 2- or 3-vector at a random bearing: centre + radius x (cos d, sin d), z fixed or uniform.
struct PolarDistribution {
  double radius_lo_m{0.0}, radius_hi_m{0.0};  ///< 0 <= lo <= hi
  double direction_lo_deg{0.0}, direction_hi_deg{360.0};
  double center_x{0.0}, center_y{0.0};
  bool uniform_in_area{false};  ///< false: uniform in radius
  std::size_t components{2};    ///< 2 or 3
  bool z_drawn{false};          ///< 3 components: z uniform in [z_lo, z_hi], else z_lo
  double z_lo{0.0}, z_hi{0.0};
};
using Distribution =
    std::variant<UniformDistribution, LogUniformDistribution, IntegerDistribution,
                 NormalDistribution, ChoiceDistribution, PolarDistribution>;

// One dispersed key and its distribution (scalar, or per component of a vector key).
struct Dispersion {
  std::string key;    ///< dotted scenario key, e.g. "cart.speed_mps"
  std::string where;  ///< "file:line" of the key in the campaign file
  Distribution distribution;
  bool scalar{true};  ///< the key's value is one value (else a list)

  // Reads and checks the distribution mapping `spec` for a key whose default value is `like`
  // (a scalar or a sequence of n). Throws ConfigError naming `where` and the key.
  static Dispersion parse(const std::string& key, const std::string& where,
                          const YAML::Node& spec, const YAML::Node& like);
  // Draws one value from the dispersion's own random stream `stream_seed`. Throws ConfigError
  // naming `where` only when a truncated normal finds no value inside [min, max].
  YAML::Node sample(std::uint64_t stream_seed) const;
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
