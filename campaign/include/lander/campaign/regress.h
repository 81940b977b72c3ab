// The statistical regression gate: compares the merged results of two campaigns run on the
// same run ids (the current one and a baseline), pair by pair.
//
// A baseline is a directory with a campaign's merged results (campaign.csv, campaign.json,
// plan.json, campaign.yaml: no runs/) and the gate's thresholds.yaml. Everything per run comes
// from campaign.csv, so the baseline needs no run directories. Runs pair by id; a pair must have
// the same scenario, the same seed and the same values of the sampled inputs both campaigns
// have, else the campaigns are not comparable (ConfigError). Runs present in one campaign only
// are left out and listed, up to a share set in thresholds.yaml (more is a ConfigError).
//
// Per scenario and overall: the landing rates and the 95 % interval of their difference
// (Newcombe's method for paired proportions, stats.h), over the pairs the simulator completed
// on both sides; the differences of the touchdown offset median and p95, the touchdown relative
// speed median and the time to land median, with paired bootstrap 95 % intervals, over the
// runs landed in both; the runs that went from landed to not landed or back (with the commands
// that rerun them from the current campaign); simulator failures apart. Each threshold of
// thresholds.yaml is a check that fails only with confidence (see Thresholds).
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace lander::campaign {

// One entry of thresholds.yaml: `key: {limit: L, reason: "why L"}`.
struct Threshold {
  double limit{0.0};
  std::string reason;
  std::string where;  ///< "file:line" of the key
};

// The gate's thresholds (BASELINE/thresholds.yaml). Keys, each optional (an absent key's check
// is not made, and the report says so):
//   landing_rate_drop_points       fails when the 95 % interval of (current - baseline)
//                                  landing rate, in percentage points, lies wholly below -limit
//   offset_p95_growth_m            fails when the difference of the p95 touchdown offset is
//                                  above limit AND its 95 % interval lies wholly above 0
//   offset_median_growth_m         the same for the median touchdown offset
//   rel_speed_median_growth_mps    the same for the median touchdown relative speed
//   time_to_land_median_growth_s   the same for the median time to land
//   simulator_failures_increase    fails when the current campaign has more than limit
//                                  simulator failures more than the baseline (paired runs)
//   unpaired_runs_max_share        not a check: the largest share (0..1) of run ids found in
//                                  only one campaign that are left out; above it the
//                                  comparison is refused (default 0.05)
// Each check is made overall and, when there are several scenarios, per scenario. The four
// touchdown checks need at least 5 runs landed in both campaigns (in the group), else they are
// reported as not evaluable (and do not fail).
struct Thresholds {
  std::string file;
  std::map<std::string, Threshold> items;

  // The known keys in the order the report lists them.
  static const std::vector<std::string>& keys();
  // Reads a thresholds file with yaml-cpp. Throws ConfigError with file:line for an unknown
  // key, a missing or non-numeric or negative limit, a missing or empty reason, or any other
  // key inside an entry.
  static Thresholds load(const std::string& path);
  // The thresholds file `lander regress --accept` writes into a baseline that has none.
  static std::string default_yaml();

  const Threshold* find(const std::string& key) const;
  double max_unpaired_share() const;
};

// One run as campaign.csv holds it. Numbers are NaN where the cell is empty.
struct RunResult {
  std::string id, scenario, outcome, status, detail;
  std::uint64_t seed{0};
  bool landed{false};
  double offset_m{NAN}, x_P_m{NAN}, y_P_m{NAN}, rel_speed_mps{NAN}, tilt_deg{NAN};
  double time_to_land_s{NAN}, wall_s{NAN};
  std::vector<std::pair<std::string, std::string>> inputs;  ///< sampled input column -> cell
  int line{0};                                              ///< where the row starts
  bool simulator_ok() const { return status == "ok"; }
};

// A merged campaign directory as the gate reads it: DIR/campaign.json and DIR/campaign.csv
// (as `lander campaign report` writes them, see merge.cpp).
struct CampaignResults {
  std::string dir;
  nlohmann::ordered_json summary;          ///< campaign.json
  std::vector<std::string> input_columns;  ///< the sampled input columns of campaign.csv
  std::vector<RunResult> runs;             ///< in file order; ids are unique

  // Throws ConfigError naming the file (and line) when either file is missing or malformed:
  // a missing column, a duplicate id, a cell that is not what its column holds.
  static CampaignResults load(const std::string& dir);
};

struct RegressOptions {
  std::string thresholds_path;  ///< default: BASELINE/thresholds.yaml
  std::string lander_binary;    ///< shown in the rerun commands (default: this executable)
  int resamples{2000};          ///< bootstrap resamples of each interval
  std::uint64_t seed{1};        ///< bootstrap stream (the report is reproducible)
};

struct RegressResult {
  nlohmann::ordered_json report;           ///< what regress.json holds
  std::vector<std::string> failed_checks;  ///< "<group>: <key>" of each failed check
  bool failed() const { return !failed_checks.empty(); }
};

// Compares CURRENT with BASELINE. Throws ConfigError for unreadable input, campaigns that are
// not paired (scenario, seed or sampled inputs differ on an id) or too many unpaired runs.
// Writes nothing.
RegressResult regress(const std::string& current_dir, const std::string& baseline_dir,
                      const RegressOptions& o = {});

struct AcceptResult {
  std::vector<std::string> copied;  ///< the files written into the baseline
  std::string thresholds_path;
  bool thresholds_written{false};  ///< a default thresholds.yaml was written (none before)
};

// Makes CURRENT the baseline: copies campaign.csv, campaign.json, plan.json and campaign.yaml
// (not runs/) into BASELINE (created if absent), each file replaced atomically; keeps its
// thresholds.yaml (after checking it loads) or writes the default one. Throws ConfigError, before
// writing anything, when CURRENT is not a complete merged campaign (missing runs) or a file is
// unreadable.
AcceptResult accept_baseline(const std::string& current_dir, const std::string& baseline_dir);

}  // namespace lander::campaign
