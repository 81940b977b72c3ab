// Flight plugins end to end, run as a user runs them (issue 49): our own stack flown through
// `--flight-plugin` gives the built-in run's files byte for byte; the example plugin lands the
// default scenario; a campaign flown by both pairs run for run in `lander regress`; bad plugins
// give clear errors or recorded simulator failures.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/json_checks.h"
#include "common/run_binary.h"

namespace {

namespace fs = std::filesystem;
using lander::test::BinaryRun;
using nlohmann::json;

// The moving-cart landings' touchdown offset limit (the campaigns' offset_limit_m).
constexpr double kMovingCartOffsetTolM = 0.10;

std::string temp_dir(const std::string& prefix) {
  std::string tmpl = "/tmp/" + prefix + ".XXXXXX";
  const char* d = mkdtemp(tmpl.data());
  if (!d) ADD_FAILURE() << "mkdtemp failed";
  return d ? d : "/tmp";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

BinaryRun lander(std::vector<std::string> args, const std::string& io_dir) {
  args.insert(args.begin(), LANDER_BINARY);
  return lander::test::run_binary(args, io_dir);
}

// A scenario of the source tree with its duration cut to `duration_s` (byte identity needs no
// landing; the frames, detections, faults and blur of those seconds are what crosses the seam).
std::string shortened(const std::string& dir, const std::string& scenario, double duration_s,
                      const std::string& extra_yaml = "") {
  const std::string text = slurp(std::string(LANDER_SOURCE_DIR) + "/scenarios/" + scenario);
  EXPECT_FALSE(text.empty()) << scenario;
  const std::regex dur("(^|\n)duration_s: *[0-9.]+");
  EXPECT_TRUE(std::regex_search(text, dur)) << scenario << " has no duration_s line";
  const std::string out = dir + "/" + scenario;
  std::ofstream(out) << std::regex_replace(text, dur, "$1duration_s: " + std::to_string(duration_s)) << "\n"
                      << extra_yaml;
  return out;
}

// Returns the plugin run's summary.json.
json expect_identical_outputs(const std::string& scenario, double duration_s, const std::string& extra_yaml = "") {
  const std::string dir = temp_dir("plugin_identity");
  const std::string s = shortened(dir, scenario, duration_s, extra_yaml);
  const BinaryRun a = lander({"run", s, "--out", dir + "/builtin", "--quiet"}, dir);
  const BinaryRun b =
      lander({"run", s, "--out", dir + "/plugin", "--quiet", "--flight-plugin", PLUGIN_lander_flight_plugin}, dir);
  EXPECT_EQ(a.code, b.code) << a.err << b.err;
  for (const char* f : {"summary.json", "trace.csv"}) {
    const std::string x = slurp(dir + "/builtin/" + f), y = slurp(dir + "/plugin/" + f);
    EXPECT_FALSE(x.empty()) << scenario << ": no " << f << "\n" << a.err;
    EXPECT_TRUE(x == y) << scenario << ": " << f << " differs between the built-in run and the plugin's";
  }
  // The same configuration flew, but for the key that chose the software.
  const std::regex plugin_line("(^|\n)plugin: [^\n]*");
  EXPECT_EQ(std::regex_replace(slurp(dir + "/builtin/flight.resolved.yaml"), plugin_line, "$1plugin: X"),
            std::regex_replace(slurp(dir + "/plugin/flight.resolved.yaml"), plugin_line, "$1plugin: X"));
  // The provenance is where they differ: builtin, or the plugin's file and sha256.
  const json fa = lander::test::parse_json(slurp(dir + "/builtin/flight_software.json"));
  const json fb = lander::test::parse_json(slurp(dir + "/plugin/flight_software.json"));
  EXPECT_EQ(lander::test::string_at(fa, "source"), "builtin");
  EXPECT_EQ(lander::test::string_at(fb, "source"), "plugin");
  EXPECT_EQ(lander::test::string_at(fb, "plugin"), fs::canonical(PLUGIN_lander_flight_plugin).string());
  EXPECT_TRUE(std::regex_match(lander::test::string_at(fb, "plugin_sha256"), std::regex("[0-9a-f]{64}")));
  const json sum = lander::test::parse_json(slurp(dir + "/plugin/summary.json"));
  EXPECT_EQ(lander::test::string_at(sum.at("flight_software"), "name"), "lander");
  // Something crossed the seam: frames were detected.
  EXPECT_GT(lander::test::number_at(sum.at("vision"), "detections"), 0) << scenario;
  return sum;
}

TEST(FlightPlugin, OurStackAsAPluginGivesTheBuiltInFilesByteForByte) {
  expect_identical_outputs("default.yaml", 20.0);  // acquisition, observe, approach
}

TEST(FlightPlugin, OurStackAsAPluginIsIdenticalWithFaults) {
  // gps_degraded (correlated GPS error, glitches, drop-outs) with the fault hooks on the
  // wire (NaN IMU, absurd GPS) and on the vision results through FrameJob::inject (pushed
  // poses, NaN poses), all while the target is tracked.
  const json sum = expect_identical_outputs("gps_degraded.yaml", 15.0,
                           "faults: {vision_outlier_t_s: 6.0, vision_outlier_frames: 4, vision_outlier_m: 0.8,\n"
                           "  nan_vision_t_s: 9.0, nan_vision_duration_s: 0.3, nan_imu_t_s: 7.0,\n"
                           "  nan_imu_duration_s: 0.05, absurd_gps_t_s: 11.0, absurd_gps_duration_s: 0.5}\n");
  // The faults reached the flight software: the outliers were injected, the samples screened.
  EXPECT_EQ(lander::test::number_at(sum.at("vision"), "outliers_injected"), 4);
  EXPECT_GT(lander::test::number_at(sum.at("rejected_samples"), "imu"), 0);
  EXPECT_GT(lander::test::number_at(sum.at("rejected_samples"), "gps"), 0);
  EXPECT_GT(lander::test::number_at(sum.at("rejected_samples"), "vision"), 0);
}

TEST(FlightPlugin, OurStackAsAPluginIsIdenticalWithMotionBlur) {
  expect_identical_outputs("motion_blur.yaml", 6.0);  // blur renders, predicted blur, deblur
}

TEST(FlightPlugin, TheExampleLandsTheDefaultScenario) {
  const std::string dir = temp_dir("plugin_pd");
  const BinaryRun r = lander({"run", std::string(LANDER_SOURCE_DIR) + "/scenarios/default.yaml", "--out", dir + "/out",
                              "--quiet", "--flight-plugin", PLUGIN_pd_lander},
                             dir);
  const std::string text = slurp(dir + "/out/summary.json");
  ASSERT_FALSE(text.empty()) << r.err;
  const json s = lander::test::parse_json(text);
  EXPECT_EQ(r.code, 0) << text;
  EXPECT_TRUE(lander::test::bool_at(s, "landed")) << text;
  EXPECT_LT(lander::test::number_at(s, "touchdown_offset_m"), kMovingCartOffsetTolM) << text;
  EXPECT_EQ(lander::test::string_at(s.at("flight_software"), "name"), "pd_lander");
}

// ---------------------------------------------------------------------------- bad plugins

// A plugin refused before anything is written: exit 2, the message names the file and why.
void expect_refused(const std::string& plugin, const std::string& why_regex) {
  const std::string dir = temp_dir("plugin_bad");
  const BinaryRun r = lander({"run", std::string(LANDER_SOURCE_DIR) + "/scenarios/default.yaml", "--out", dir + "/out",
                              "--quiet", "--flight-plugin", plugin},
                             dir);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(std::regex_search(r.err, std::regex(why_regex))) << r.err;
  EXPECT_NE(r.err.find(fs::path(plugin).filename().string()), std::string::npos) << "the message names the file: " << r.err;
  EXPECT_FALSE(fs::exists(dir + "/out/summary.json")) << "nothing is written for a bad input";
}

TEST(FlightPlugin, AMissingFileIsRefused) { expect_refused("/nonexistent/libnothing.so", "no such file"); }

TEST(FlightPlugin, AFileThatIsNotASharedLibraryIsRefused) {
  const std::string dir = temp_dir("plugin_text");
  std::ofstream(dir + "/libtext.so") << "this is not an ELF file\n";
  expect_refused(dir + "/libtext.so", "cannot load it as a shared library");
}

TEST(FlightPlugin, ALibraryWithoutTheEntryPointsIsRefused) {
  // Any shared library without the three entry points: libyaml-cpp is one the build links.
  const std::string dir = temp_dir("plugin_nosym");
  const std::string lib = dir + "/libempty.so";
  std::ofstream(dir + "/empty.c") << "int lander_test_nothing(void) { return 0; }\n";
  const BinaryRun cc = lander::test::run_binary({"/usr/bin/cc", "-shared", "-fPIC", "-o", lib, dir + "/empty.c"}, dir);
  ASSERT_EQ(cc.code, 0) << cc.err;
  expect_refused(lib, "no entry point 'lander_flight_plugin_api_version'");
}

TEST(FlightPlugin, AnotherApiVersionIsRefused) {
  expect_refused(PLUGIN_bad_plugin_version, "built against flight-software API version 999");
}

TEST(FlightPlugin, ACreateThatFailsIsRefusedWithItsMessage) {
  expect_refused(PLUGIN_bad_plugin_null, "could not create its flight software: the bad plugin refuses to fly");
}

TEST(FlightPlugin, AThrowInACallbackEndsTheRunWithTheMethodNamed) {
  const std::string dir = temp_dir("plugin_throw");
  const BinaryRun r = lander({"run", std::string(LANDER_SOURCE_DIR) + "/scenarios/default.yaml", "--out", dir + "/out",
                              "--quiet", "--flight-plugin", PLUGIN_bad_plugin_throw},
                             dir);
  EXPECT_EQ(r.code, 1) << "a run-time failure, not a bad input: " << r.err;
  const json s = lander::test::parse_json(slurp(dir + "/out/summary.json"));
  EXPECT_EQ(lander::test::string_at(s, "outcome"), "error");
  const std::string detail = lander::test::string_at(s, "outcome_detail");
  EXPECT_NE(detail.find("'bad_plugin' threw in on_imu: deliberate failure"), std::string::npos) << detail;
}

// A campaign of one short run flown by a plugin that crashes or hangs: recorded as that run's
// simulator failure with its reason; the campaign itself finishes (exit 1: a failure).
json one_run_campaign(const std::string& plugin, const std::string& dir, const std::vector<std::string>& extra) {
  std::ofstream(dir + "/c.yaml") << "name: bad_plugin\nseed: 3\n"
                                 << "scenarios:\n  - {file: " << LANDER_SOURCE_DIR << "/scenarios/static_platform.yaml, runs: 1}\n"
                                 << "dispersions:\n  duration_s: {constant: 5}\n";
  std::vector<std::string> args = {"campaign", "run", dir + "/c.yaml", "--out", dir + "/out", "--jobs", "1",
                                   "--no-progress", "--flight-plugin", plugin};
  args.insert(args.end(), extra.begin(), extra.end());
  const BinaryRun r = lander(args, dir);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  const json rec = lander::test::parse_json(slurp(dir + "/out/runs/static_platform-0000/run.json"));
  return rec;
}

TEST(FlightPlugin, ASegfaultIsARecordedCrashOfThatRun) {
  const std::string dir = temp_dir("plugin_segv");
  const json rec = one_run_campaign(PLUGIN_bad_plugin_segv, dir, {});
  EXPECT_EQ(lander::test::string_at(rec, "status"), "crashed");
  EXPECT_NE(lander::test::string_at(rec, "detail").find("signal 11 (Segmentation fault)"), std::string::npos) << rec.dump();
  EXPECT_EQ(lander::test::string_at(rec.at("flight_software"), "name"), "bad_plugin") << "run.json names who crashed";
  EXPECT_TRUE(fs::exists(dir + "/out/campaign.csv")) << "the campaign was merged despite the crash";
}

TEST(FlightPlugin, AHangIsARecordedHungRun) {
  const std::string dir = temp_dir("plugin_hang");
  // 20 s: the run's start (model, renderer) takes ~2 s, the plugin hangs at 0.5 s of flight.
  const json rec = one_run_campaign(PLUGIN_bad_plugin_hang, dir, {"--timeout-s", "20"});
  EXPECT_EQ(lander::test::string_at(rec, "status"), "hung");
  EXPECT_NE(lander::test::string_at(rec, "detail").find("killed after"), std::string::npos) << rec.dump();
}

// ------------------------------------------------------------------- two stacks, one campaign

TEST(FlightPlugin, TwoStacksOnOneCampaignPairRunForRunInRegress) {
  const std::string dir = temp_dir("plugin_pair");
  const std::string smoke = std::string(LANDER_SOURCE_DIR) + "/campaigns/smoke.yaml";
  // Three of the smoke campaign's runs, one per scenario (same ids, seeds and samples).
  const std::string only = "default-0000,cart_1mps_turning-0000,static_platform-0000";
  const BinaryRun ours = lander({"campaign", "run", smoke, "--out", dir + "/ours", "--jobs", "2", "--only", only,
                                 "--no-progress"},
                                dir);
  ASSERT_NE(ours.code, 2) << ours.err;
  const BinaryRun pd = lander({"campaign", "run", smoke, "--out", dir + "/pd", "--jobs", "2", "--only", only,
                               "--no-progress", "--flight-plugin", PLUGIN_pd_lander},
                              dir);
  ASSERT_NE(pd.code, 2) << pd.err;
  // campaign.csv says who flew each run.
  const std::string csv = slurp(dir + "/pd/campaign.csv");
  EXPECT_NE(csv.find(",pd_lander,1.0,"), std::string::npos) << csv;
  const BinaryRun rg = lander({"regress", dir + "/pd", "--baseline", dir + "/ours", "--thresholds",
                               std::string(LANDER_SOURCE_DIR) + "/regression/smoke/thresholds.yaml"},
                              dir);
  ASSERT_TRUE(rg.code == 0 || rg.code == 1) << rg.out << rg.err;
  EXPECT_NE(rg.out.find("flight software: pd_lander 1.0 (current), lander 0.1.0 (baseline)"), std::string::npos)
      << rg.out;
  EXPECT_NE(rg.out.find("paired runs: 3;"), std::string::npos) << rg.out;
  const json rj = lander::test::parse_json(slurp(dir + "/pd/regress.json"));
  EXPECT_EQ(lander::test::number_at(rj.at("pairing"), "paired"), 3);
}

}  // namespace
