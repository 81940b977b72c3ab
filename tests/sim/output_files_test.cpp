// Output files: written under a temporary name and renamed when complete; a failed write
// throws naming the file and leaves nothing under the real name; JSON through nlohmann with
// keys in order, null for NaN and round-trip numbers; one CSV writer.
#include "lander/sim/util/output_files.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "common/json_checks.h"
#include "lander/sim/util/stats.h"

namespace lander::sim {
namespace {

namespace fs = std::filesystem;

std::string temp_dir() {
  char name[] = "/tmp/lander_out_XXXXXX";
  return mkdtemp(name) ? name : "";
}

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(AtomicFile, AppearsOnlyOnCommit) {
  const std::string dir = temp_dir();
  {
    AtomicFile f(dir + "/a.txt");
    f.write("hello\n");
    EXPECT_FALSE(fs::exists(dir + "/a.txt"));  // only the temporary file so far
    EXPECT_TRUE(fs::exists(dir + "/a.txt.tmp." + std::to_string(getpid())));
    f.commit();
  }
  EXPECT_EQ(slurp(dir + "/a.txt"), "hello\n");
  EXPECT_FALSE(fs::exists(dir + "/a.txt.tmp." + std::to_string(getpid())));
  {
    AtomicFile f(dir + "/b.txt");
    f.write("half");
  }  // not committed: nothing under either name
  EXPECT_FALSE(fs::exists(dir + "/b.txt"));
  EXPECT_FALSE(fs::exists(dir + "/b.txt.tmp." + std::to_string(getpid())));
  fs::remove_all(dir);
}

TEST(AtomicFile, CannotCreateNamesTheFile) {
  try {
    write_file_atomic("/no/such/dir/summary.json", "{}");
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find("/no/such/dir/summary.json"), std::string::npos)
        << e.what();
  }
}

// A full disk: the temporary file is /dev/full (through a symlink), whose writes fail with
// ENOSPC once the stream flushes. The error names the file; nothing appears under its name.
TEST(AtomicFile, FullDiskThrowsNamingTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  const std::string dir = temp_dir();
  fs::create_symlink("/dev/full", dir + "/trace.csv.tmp." + std::to_string(getpid()));
  try {
    CsvWriter w(dir + "/trace.csv", {"t_s", "x_m"});
    for (int i = 0; i < 100000; ++i) w.num(i * 0.01, 4).num(1.0, 5).end_row();
    w.commit();
    FAIL() << "a write to a full disk went unnoticed";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/trace.csv"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/trace.csv"));
  fs::remove_all(dir);
}

TEST(CsvWriter, FixedDecimalsQuotingAndRowWidth) {
  const std::string dir = temp_dir();
  CsvWriter w(dir + "/t.csv", {"t_s", "mode", "x_m", "n"});
  w.num(1.23456, 4).text("observe").num(-0.5, 2).integer(3).end_row();
  w.num(std::nan(""), 3).text("a,\"b\"").num(std::numeric_limits<double>::infinity(), 1)
      .integer(-7)
      .end_row();
  EXPECT_THROW(w.num(1, 1).end_row(), std::logic_error);  // one cell for four columns
  EXPECT_EQ(w.rows(), 2u);
  w.commit();
  EXPECT_EQ(slurp(dir + "/t.csv"),
            "t_s,mode,x_m,n\n1.2346,observe,-0.50,3\nnan,\"a,\"\"b\"\"\",inf,-7\n");
  fs::remove_all(dir);
}

TEST(JsonText, OrderedKeysNullForNonFiniteAndRoundTripNumbers) {
  nlohmann::ordered_json j;
  j["zeta"] = 1;
  j["alpha"] = std::nan("");
  j["x"] = 0.1 + 0.2;
  j["inf"] = -std::numeric_limits<double>::infinity();
  j["text"] = std::string("quote \" newline \n tab \t nul ") + '\0' + " bell \a end";
  const std::string text = json_text(j);
  EXPECT_LT(text.find("\"zeta\""), text.find("\"alpha\""));  // insertion order
  const nlohmann::json back = test::parse_json(text);
  EXPECT_TRUE(back.at("alpha").is_null());
  EXPECT_TRUE(back.at("inf").is_null());
  EXPECT_EQ(back.at("x").get<double>(), 0.1 + 0.2);  // every bit
  EXPECT_EQ(back.at("text").get<std::string>(), j["text"].get<std::string>());  // lossless
  EXPECT_EQ(text.back(), '\n');
  // Invalid UTF-8 (a path from the user) is written, not thrown.
  nlohmann::ordered_json bad;
  bad["path"] = std::string("a\xff\xfe b");
  EXPECT_NO_THROW(test::parse_json(json_text(bad)));
}

TEST(Stats, SummaryOfASampleLeavesNonFiniteValuesOut) {
  const SampleSummary s = summarize({4.0, 1.0, std::nan(""), 3.0, 2.0,
                                     std::numeric_limits<double>::infinity()});
  EXPECT_EQ(s.n, 4u);
  EXPECT_EQ(s.non_finite, 2u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.var, 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.median, 2.5);          // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.p95, 3.0 + 0.85 * 1.0);  // type 7: h = 3 * 0.95 = 2.85
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  const SampleSummary e = summarize({});
  EXPECT_EQ(e.n, 0u);
  EXPECT_TRUE(std::isnan(e.mean) && std::isnan(e.median) && std::isnan(e.max));
  EXPECT_TRUE(std::isnan(summarize({7.0}).var));
  EXPECT_DOUBLE_EQ(summarize({7.0}).p95, 7.0);
  EXPECT_TRUE(test::parse_json(to_json(e).dump()).at("mean").is_null());
}

TEST(Stats, ErrorStatsSkipsNonFinite) {
  ErrorStats e;
  e.add(0.3);
  e.add(std::nan(""));
  e.add(-0.4);
  EXPECT_EQ(e.n, 2u);
  EXPECT_EQ(e.non_finite, 1u);
  EXPECT_NEAR(e.rmse_m(), std::sqrt(0.125), 1e-15);
  EXPECT_DOUBLE_EQ(e.max_abs_m, 0.4);
}

}  // namespace
}  // namespace lander::sim
