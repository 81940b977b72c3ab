// The `lander` command line with bad input: a clear message naming what is wrong, exit code
// 2, and no partial output.
#include <gtest/gtest.h>

#include "tools/support/cli.h"

#include <sys/stat.h>

#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace {

using lander::test::run_lander;

bool exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

std::string temp_dir() { return lander::test::make_temp_dir("lander_cli"); }

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Cli, NoArgumentsPrintsUsageAndFails) {
  const auto r = run_lander("");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("usage"), std::string::npos) << r.output;
}

TEST(Cli, UnknownCommandIsNamed) {
  const auto r = run_lander("fly-to-the-moon");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("fly-to-the-moon"), std::string::npos) << r.output;
}

// The estimator bench's condition flags that contradict each other are usage errors naming
// both, before any frame is rendered (and no JSON is written).
TEST(Cli, BenchEstimatorContradictoryConditionFlagsAreNamed) {
  const std::string dir = temp_dir();
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {"--no-camera --camera-only", "--no-camera"},
           {"--shadows-only --camera-only", "--camera-only"},
           {"--no-shadows --shadows", "--no-shadows"}}) {
    const auto r = run_lander("bench estimator --json " + dir + "/b.json " + flags);
    EXPECT_EQ(r.code, 2) << flags << "\n" << r.output;
    EXPECT_NE(r.output.find(named), std::string::npos) << flags << "\n" << r.output;
    EXPECT_FALSE(exists(dir + "/b.json")) << flags;
  }
}

TEST(Cli, MissingScenarioFileIsNamedAndNothingIsWritten) {
  const std::string dir = temp_dir();
  const auto r = run_lander("run " + dir + "/nope.yaml --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("nope.yaml"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, UnknownKeyIsRejectedWithFileLineAndKey) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml",
                                      "name: t\n"
                                      "camera:\n"
                                      "  rate_hz: 30\n"
                                      "  exposure_msec: 3\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("s.yaml:4"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("camera.exposure_msec"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, BadValueNamesTheKey) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml", "camera:\n  exposure_ms: -3\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("camera.exposure_ms"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

// Bad input exits 2 before anything is written, with file:line and the full dotted key path.
void expect_bad_scenario(const std::string& text, const std::string& where_suffix,
                         const std::string& needle) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml", text);
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2) << text << "\n" << r.output;
  EXPECT_NE(r.output.find(yaml + where_suffix), std::string::npos) << text << "\n" << r.output;
  EXPECT_NE(r.output.find(needle), std::string::npos) << text << "\n" << r.output;
  EXPECT_FALSE(exists(dir + "/out")) << text;
}

TEST(Cli, ImageTooLargeForTheOffscreenBufferIsBadInput) {
  // Used to fail at run time with a MuJoCo framebuffer error and exit 1.
  expect_bad_scenario("name: big\ncamera:\n  intrinsics:\n    width_px: 100000\n", ":4: ",
                      "'camera.intrinsics.width_px'");
}

TEST(Cli, ValueErrorsNameTheFullDottedPath) {
  expect_bad_scenario("world:\n  dt_ms: 9\n", ":2: ", "'world.dt_ms'");  // was 'physics.dt_ms'
  expect_bad_scenario("camera:\n  rate_hz: 0\n", ":2: ", "'camera.rate_hz'");
  expect_bad_scenario("sensors:\n  gps:\n    latency_ms: -5\n", ":3: ",
                      "'sensors.gps.latency_ms'");
  expect_bad_scenario("render:\n  backend: vulkan\n", ":2: ", "'render.backend'");
  expect_bad_scenario("video:\n  chase_width_px: 641\n", ":2: ", "'video.chase_width_px'");
}

TEST(Cli, DuplicateKeyIsBadInput) {
  expect_bad_scenario("seed: 1\nduration_s: 5\nseed: 2\n", ":3: ", "duplicate key 'seed'");
}

TEST(Cli, EmptyScenarioFileIsBadInput) {
  expect_bad_scenario("", ":1: ", "empty");
  expect_bad_scenario("# nothing but a comment\n", ":1: ", "empty");
}

TEST(Cli, WrongTypeNamesTheKeyAndLine) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml", "seed: 1\nduration_s: forever\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("s.yaml:2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("duration_s"), std::string::npos) << r.output;
}

TEST(Cli, YamlSyntaxErrorNamesTheLine) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml", "name: t\ncamera: [1, 2\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("s.yaml:"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, MissingModelFileIsNamedAndNothingIsWritten) {
  const std::string dir = temp_dir();
  const std::string yaml = write_file(dir, "s.yaml", "world:\n  model: /no/such/world.xml\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("/no/such/world.xml"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, UnreadableModelIsReportedAndNothingIsWritten) {
  const std::string dir = temp_dir();
  const std::string model = write_file(dir, "broken.xml", "<mujoco><worldbody><body></mujoco>");
  const std::string yaml = write_file(dir, "s.yaml", "world:\n  model: " + model + "\n");
  const auto r = run_lander("run " + yaml + " --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("broken.xml"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, MissingOutOptionIsAUsageError) {
  const auto r = run_lander("run " + std::string(LANDER_SCENARIOS_DIR) + "/flyover.yaml");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
}

TEST(Cli, UnknownOptionIsNamed) {
  const auto r = run_lander("run " + std::string(LANDER_SCENARIOS_DIR) + "/flyover.yaml --out /tmp/x --fast");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("--fast"), std::string::npos) << r.output;
}

// Given --help (or -h) among a command's or benchmark's arguments, when the command does not
// take it itself, then its usage line is printed and the exit status is 0, nothing run; any
// other unknown option stays an error.
TEST(Cli, HelpAmongTheArgumentsPrintsTheUsage) {
  for (const char* cmd : {"run --help", "bench frames -h", "detect --help", "batch --help"}) {
    const auto r = run_lander(cmd);
    EXPECT_EQ(r.code, 0) << cmd << ": " << r.output;
    EXPECT_NE(r.output.find("docs/reference/cli.md"), std::string::npos) << cmd << ": " << r.output;
  }
  const auto r = run_lander("bench frames --helpful");
  EXPECT_EQ(r.code, 2) << r.output;
}

}  // namespace

namespace {

TEST(Cli, BatchWithABadSeedCountIsNamedAndNothingIsWritten) {
  const std::string dir = temp_dir();
  const std::string scen = std::string(LANDER_SCENARIOS_DIR) + "/default.yaml";
  for (const char* bad : {"abc", "1.5", "0", "-3"}) {
    const auto r = run_lander("batch " + scen + " --seeds " + bad + " --out " + dir + "/out");
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.output.find("--seeds"), std::string::npos) << r.output;
  }
  const auto missing = run_lander("batch " + scen + " --out " + dir + "/out");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.output.find("--seeds"), std::string::npos) << missing.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, BatchOfAScriptedFlightIsRefused) {
  const std::string dir = temp_dir();
  const auto r = run_lander("batch " + std::string(LANDER_SCENARIOS_DIR) +
                            "/flyover.yaml --seeds 2 --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("closed_loop"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

TEST(Cli, RunWithANegativeSeedIsNamed) {
  const std::string dir = temp_dir();
  const auto r = run_lander("run " + std::string(LANDER_SCENARIOS_DIR) +
                            "/default.yaml --seed -1 --out " + dir + "/out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("--seed"), std::string::npos) << r.output;
  EXPECT_FALSE(exists(dir + "/out"));
}

}  // namespace
