// Output paths built from names (campaign runs, scenario names) must be just bytes: a run with
// video into a directory whose name holds quotes, `$()`, backticks, a semicolon, spaces and a
// newline writes every output under exactly that name and runs no command (no shell anywhere:
// ffmpeg is started from an argument vector).
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "common/json_checks.h"
#include "tools/support/cli.h"

namespace {

bool exists(const std::string& p) {
  struct stat st;
  return lstat(p.c_str(), &st) == 0;
}

std::size_t file_size(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 ? static_cast<std::size_t>(st.st_size) : 0;
}

TEST(HostilePaths, RunWithVideoWritesUnderTheExactNameAndRunsNothing) {
  const std::string base = lander::test::make_temp_dir("lander_hostile");
  ASSERT_FALSE(base.empty());
  // Every way a shell would have run `touch INJECTED` (in the working directory, the run's
  // output directory or its parent) if it ever saw these names. No '/' in them: a slash is a
  // directory separator, not part of a name.
  const std::string marker = "INJECTED";
  const std::string name = "run 'a' \"b\" $(touch " + marker + ") `touch " + marker +
                           "`; touch " + marker + " &&\n second line -x";
  // The scenario file lives in a hostile directory too.
  const std::string scen_dir_name = "scen 'q' $(touch " + marker + ")";
  const std::string scen_dir = base + "/" + scen_dir_name;
  ASSERT_TRUE(std::filesystem::create_directory(scen_dir));
  std::string text = lander::test::slurp(std::string(LANDER_SCENARIOS_DIR) + "/flyover.yaml");
  const auto pos = text.find("duration_s: 24");
  ASSERT_NE(pos, std::string::npos);
  text.replace(pos, 14, "duration_s: 0.5");  // 15 frames of the scripted descent
  const std::string scen = scen_dir + "/s.yaml";
  std::ofstream(scen) << text;

  const std::string out = base + "/" + name;
  const auto r = lander::test::run_lander({"run", scen, "--out", out, "--video", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.signal, 0) << r.output;
  for (const std::string& where : {std::filesystem::current_path().string(), base, out}) {
    EXPECT_FALSE(exists(where + "/" + marker)) << "a shell ran part of the path, in " << where;
  }
  for (const char* f : {"summary.json", "trace.csv", "scenario.resolved.yaml",
                        "performance.json", "camera.mp4", "chase.mp4"}) {
    EXPECT_GT(file_size(out + "/" + f), 0u) << f;
  }
  EXPECT_GT(file_size(out + "/camera.mp4"), 1000u);  // frames, not just a header
  // Nothing else: no temporary or half file left, nothing written next to the directory.
  std::set<std::string> in_out, in_base;
  for (const auto& e : std::filesystem::directory_iterator(out)) {
    in_out.insert(e.path().filename().string());
  }
  for (const auto& e : std::filesystem::directory_iterator(base)) {
    in_base.insert(e.path().filename().string());
  }
  EXPECT_EQ(in_out, (std::set<std::string>{"summary.json", "trace.csv", "scenario.resolved.yaml",
                                           "performance.json", "camera.mp4", "chase.mp4"}));
  EXPECT_EQ(in_base, (std::set<std::string>{name, scen_dir_name}));
  const nlohmann::json summary = lander::test::read_json_file(out + "/summary.json");
  EXPECT_EQ(lander::test::string_at(summary, "outcome"), "scripted_flight_complete");
  EXPECT_EQ(lander::test::number_at(summary, "vision.frames"), 15);
  std::filesystem::remove_all(base);
}

}  // namespace
