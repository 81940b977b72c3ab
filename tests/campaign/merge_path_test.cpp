// The merge of a campaign with painted routes (issue 14): campaign.csv gets the path-following
// columns and campaign.json the path_following block; a campaign without a route keeps its
// columns exactly. Fake run directories with known summaries, parsed back with real parsers.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "lander/campaign/merge.h"
#include "support/campaign_support.h"

namespace {

using json = nlohmann::json;

void write(const std::string& path, const json& j) { std::ofstream(path) << j.dump(2); }

// A run directory with run.json and summary.json.
void fake_run(const std::string& dir, const std::string& id, const std::string& outcome, const json& path_block) {
  const std::string r = dir + "/runs/" + id;
  std::filesystem::create_directories(r);
  write(r + "/run.json", {{"id", id}, {"status", "ok"}, {"outcome", outcome}, {"landed", outcome == "landed"},
                          {"detail", "fake"}, {"wall_s", 1.0}});
  json s = {{"outcome", outcome}, {"landed", outcome == "landed"}, {"touchdown_offset_m", nullptr}};
  if (!path_block.is_null()) s["path_following"] = path_block;
  write(r + "/summary.json", s);
}

void fake_plan(const std::string& dir, const std::vector<std::string>& ids) {
  json runs = json::array();
  for (const std::string& id : ids) {
    runs.push_back({{"id", id}, {"scenario", "s"}, {"scenario_file", "s.yaml"}, {"index", 0}, {"seed", 1},
                    {"sampled", json::object()}});
  }
  write(dir + "/plan.json", {{"schema_version", 1}, {"name", "t"}, {"master_seed", 1}, {"campaign_file", "c.yaml"},
                             {"offset_limit_m", 0.1}, {"dispersion_keys", json::array()}, {"runs", runs}});
}

std::size_t col(const lander::test::Csv& c, const std::string& name) {
  const auto it = std::find(c.header.begin(), c.header.end(), name);
  EXPECT_NE(it, c.header.end()) << "no column " << name;
  return static_cast<std::size_t>(it - c.header.begin());
}

TEST(MergePath, RouteCampaignsGetThePathColumnsAndBlock) {
  const std::string dir = lander::test::temp_dir("merge_path");
  fake_plan(dir, {"s-0000", "s-0001"});
  fake_run(dir, "s-0000", "route_end",
           {{"covered", true}, {"time_to_cover_s", 47.5}, {"cross_track_mean_m", 0.08}, {"cross_track_p95_m", 0.2},
            {"cross_track_max_after_capture_m", 0.3}, {"target_share", 0.95}});
  // A run whose route was not covered: null time (NaN) must stay empty, not read as 0.
  fake_run(dir, "s-0001", "timeout",
           {{"covered", false}, {"time_to_cover_s", nullptr}, {"cross_track_mean_m", 0.12},
            {"cross_track_p95_m", 0.3}, {"cross_track_max_after_capture_m", 0.4}, {"target_share", 0.9}});
  lander::campaign::MergeOptions o;
  o.html = false;
  const auto m = lander::campaign::merge_campaign(dir, o);
  const json pf = json::parse(lander::test::read_text(dir + "/campaign.json")).at("overall").at("path_following");
  EXPECT_EQ(pf.at("runs").get<int>(), 2);
  EXPECT_EQ(pf.at("covered").get<int>(), 1);
  EXPECT_EQ(pf.at("route_end").get<int>(), 1);
  EXPECT_EQ(pf.at("time_to_cover_s").at("n").get<int>(), 1);
  EXPECT_DOUBLE_EQ(pf.at("cross_track_mean_m").at("mean").get<double>(), 0.10);
  EXPECT_DOUBLE_EQ(pf.at("cross_track_mean_m").at("max").get<double>(), 0.12);
  const auto csv = lander::test::read_csv(dir + "/campaign.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  const std::size_t c_cov = col(csv, "path_covered"), c_t = col(csv, "path_time_to_cover_s"),
                    c_m = col(csv, "path_cross_track_mean_m");
  for (const auto& row : csv.rows) {
    if (row.at(0) == "s-0000") {
      EXPECT_EQ(row.at(c_cov), "1");
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_t)), 47.5);
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_m)), 0.08);
    } else {
      EXPECT_EQ(row.at(c_cov), "0");
      EXPECT_EQ(row.at(c_t), "");
    }
  }
}

TEST(MergePath, CampaignsWithoutARouteKeepTheirColumns) {
  const std::string dir = lander::test::temp_dir("merge_nopath");
  fake_plan(dir, {"s-0000"});
  fake_run(dir, "s-0000", "timeout", nullptr);
  lander::campaign::MergeOptions o;
  o.html = false;
  lander::campaign::merge_campaign(dir, o);
  const json overall = json::parse(lander::test::read_text(dir + "/campaign.json")).at("overall");
  EXPECT_FALSE(overall.contains("path_following"));
  const auto csv = lander::test::read_csv(dir + "/campaign.csv");
  EXPECT_EQ(std::count(csv.header.begin(), csv.header.end(), "path_covered"), 0);
  // ... detail, then who flew (flight software, version, plugin sha256), nothing after.
  ASSERT_GE(csv.header.size(), 4u);
  EXPECT_EQ(csv.header[csv.header.size() - 4], "detail");
  EXPECT_EQ(csv.header.back(), "flight_plugin_sha256");
}

// A moving deck's campaign (issue 56): the deck's figures at first contact and the chosen
// touchdown instant (the last deck_cut) become columns; a run without deck figures leaves
// them empty, never 0.
TEST(MergeDeck, DeckCampaignsGetTheDeckColumns) {
  const std::string dir = lander::test::temp_dir("merge_deck");
  fake_plan(dir, {"s-0000", "s-0001"});
  fake_run(dir, "s-0000", "landed", nullptr);
  fake_run(dir, "s-0001", "timeout", nullptr);
  const std::string summary = dir + "/runs/s-0000/summary.json";
  json s = json::parse(lander::test::read_text(summary));
  s["touchdown"] = {{"t_s", 20.25},           {"rel_vertical_speed_mps", -0.31}, {"deck_tilt_deg", 2.5},
                    {"deck_heave_m", -0.12},  {"deck_vz_mps", 0.04},             {"mode_at_contact", "touchdown"}};
  s["landing_decision"] = {{"events", json::array({{{"t_s", 19.5}, {"what", "deck_window"}},
                                                   {{"t_s", 19.9}, {"what", "deck_cut"}},
                                                   {{"t_s", 20.1}, {"what", "deck_cut"}}})}};
  write(summary, s);
  lander::campaign::MergeOptions o;
  o.html = false;
  lander::campaign::merge_campaign(dir, o);
  const auto csv = lander::test::read_csv(dir + "/campaign.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.header.back(), "deck_cut_t_s");
  const std::size_t c_rel = col(csv, "touchdown_rel_vertical_speed_mps"), c_tilt = col(csv, "touchdown_deck_tilt_deg"),
                    c_t = col(csv, "contact_t_s"), c_mode = col(csv, "contact_mode"), c_cut = col(csv, "deck_cut_t_s");
  for (const auto& row : csv.rows) {
    if (row.at(0) == "s-0000") {
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_rel)), -0.31);
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_tilt)), 2.5);
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_t)), 20.25);
      EXPECT_EQ(row.at(c_mode), "touchdown");
      EXPECT_DOUBLE_EQ(std::stod(row.at(c_cut)), 20.1);  // the last cut
    } else {
      EXPECT_EQ(row.at(c_rel), "");
      EXPECT_EQ(row.at(c_cut), "");
    }
  }
}

TEST(MergeDeck, CampaignsWithoutADeckHaveNoDeckColumns) {
  const std::string dir = lander::test::temp_dir("merge_nodeck");
  fake_plan(dir, {"s-0000"});
  fake_run(dir, "s-0000", "landed", nullptr);
  lander::campaign::MergeOptions o;
  o.html = false;
  lander::campaign::merge_campaign(dir, o);
  const auto csv = lander::test::read_csv(dir + "/campaign.csv");
  EXPECT_EQ(std::count(csv.header.begin(), csv.header.end(), "touchdown_deck_tilt_deg"), 0);
  EXPECT_EQ(csv.header.back(), "flight_plugin_sha256");
}

}  // namespace
