// Merging a campaign directory: whatever runs are complete (DIR/runs/<id>/run.json and the
// run's summary.json) into DIR/campaign.csv (one row per run) and DIR/campaign.json
// (statistics per scenario and overall, worst runs with their rerun commands, and which
// dispersed inputs go with the error or the failures), then DIR/report.html through
// tools/campaign_report.py (matplotlib). Missing runs are listed, not fatal.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lander::campaign {

struct MergeResult {
  int planned{0};
  int complete{0};
  int simulator_failures{0};
  std::vector<std::string> missing;
  nlohmann::ordered_json campaign;  ///< what campaign.json holds
  bool html_written{false};
  std::string html_error;           ///< why report.html could not be made
};

struct MergeOptions {
  bool html{true};              ///< also write report.html
  std::string lander_binary;    ///< shown in the rerun commands (default: this executable)
};

// Throws ConfigError when DIR has no readable plan.json.
MergeResult merge_campaign(const std::string& dir, const MergeOptions& o = {});

// A string as one shell word, for the commands the report shows a person ('...' quoting).
std::string shell_quote(const std::string& s);

}  // namespace lander::campaign
