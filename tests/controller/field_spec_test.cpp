// The field spec of the params visitor (core/include/lander/core/field_spec.h): ranges, their
// messages, and check_fields() on a small struct.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lander/core/field_spec.h"
#include "lander/core/params_io.h"

namespace lander {
namespace {

TEST(FieldRange, MessagesSayTheBoundAsTheOldRequiresDid) {
  EXPECT_EQ(range::positive.problem(), "must be > 0");
  EXPECT_EQ(range::non_negative.problem(), "must be >= 0");
  EXPECT_EQ(range::at_least(1).problem(), "must be >= 1");
  EXPECT_EQ(range::greater_than(0.25).problem(), "must be > 0.25");
  EXPECT_EQ(range::at_most(5).problem(), "must be <= 5");
  EXPECT_EQ(range::closed(0, 1).problem(), "must be in [0, 1]");
  EXPECT_EQ(range::open(0, 80).problem(), "must be in (0, 80)");
  EXPECT_EQ(range::open_closed(0, 0.5).problem(), "must be in (0, 0.5]");
  EXPECT_EQ(range::closed_open(-400, 1e4).problem(), "must be in [-400, 10000)");
  EXPECT_EQ(range::at_least(4).because("planar PnP needs four points").problem(),
            "must be >= 4 (planar PnP needs four points)");
  EXPECT_EQ(range::any.problem(), "");
}

TEST(FieldRange, EndsAreOpenOrClosedAndNaNIsOutsideAnyBoundedRange) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(range::positive.contains(0.0));
  EXPECT_TRUE(range::positive.contains(1e-300));
  EXPECT_TRUE(range::non_negative.contains(0.0));
  EXPECT_FALSE(range::non_negative.contains(-1e-300));
  EXPECT_TRUE(range::closed(0, 1).contains(1.0));
  EXPECT_FALSE(range::closed_open(0, 1).contains(1.0));
  EXPECT_FALSE(range::open_closed(0, 1).contains(0.0));
  EXPECT_FALSE(range::positive.contains(nan));
  EXPECT_FALSE(range::at_most(1).contains(nan));
  EXPECT_TRUE(range::any.contains(nan));  // unbounded: checks nothing
  EXPECT_FALSE(range::closed(0, 1).contains(std::numeric_limits<double>::infinity()));
}

struct Probe {
  double rate_hz{30};
  double exposure_s{0.005};
  int count{1};
  Eigen::Vector3d gains{1, 2, 3};
  std::string name{"x"};
  void validate() const { check_fields(*this); }
};

template <class V>
void visit_fields(V& v, Probe& p) {
  v("rate_hz", p.rate_hz, range::open_closed(0, 240), "Hz", "frame rate");
  v("exposure_ms", p.exposure_s, range::open_closed(0, 5), "ms", "exposure time", 1e-3);
  v("count", p.count, range::at_least(1), "", "how many");
  v("gains", p.gains, range::positive, "1/s", "gains");
  v("name", p.name, range::any, "", "a name");
}

std::string problem_of(const Probe& p, std::string* key) {
  try {
    p.validate();
  } catch (const ConfigError& e) {
    *key = e.key();
    return e.problem();
  }
  return "";
}

TEST(FieldChecker, NamesTheKeyAndTheBoundOfTheFirstFieldOutside) {
  std::string key;
  Probe p;
  EXPECT_EQ(problem_of(p, &key), "");
  p.rate_hz = 241;
  EXPECT_EQ(problem_of(p, &key), "must be in (0, 240]");
  EXPECT_EQ(key, "rate_hz");
  p = Probe{};
  p.count = 0;
  EXPECT_EQ(problem_of(p, &key), "must be >= 1");
  EXPECT_EQ(key, "count");
  p = Probe{};
  p.gains.y() = 0;
  EXPECT_EQ(problem_of(p, &key), "all entries must be > 0");
  EXPECT_EQ(key, "gains");
}

// The range is in the YAML unit and compared exactly against the value read (5 ms is read as
// 5 * 1e-3 and is inside (0, 5]; 5.001 ms is not).
TEST(FieldChecker, ScaledRangesCompareTheValueAsRead) {
  std::string key;
  Probe p;
  read_params(YAML::Load("exposure_ms: 5"), "x.yaml", p);
  EXPECT_EQ(p.exposure_s, 5 * 1e-3);
  EXPECT_THROW(read_params(YAML::Load("exposure_ms: 5.001"), "x.yaml", p), ConfigError);
  try {
    Probe q;
    read_params(YAML::Load("a: 1\nexposure_ms: -1\n"), "x.yaml", q);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    // an unknown key is reported before any range
    EXPECT_NE(std::string(e.what()).find("'a'"), std::string::npos) << e.what();
  }
  try {
    Probe q;
    read_params(YAML::Load("rate_hz: 30\nexposure_ms: -1\n"), "x.yaml", q);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "x.yaml:2: invalid value for 'exposure_ms': must be in (0, 5]");
  }
}

TEST(FieldLister, ListsKeyTypeUnitRangeAndDescription) {
  std::vector<FieldInfo> out;
  FieldLister l(&out, "camera.");
  Probe p;
  visit_fields(l, p);
  ASSERT_EQ(out.size(), 5u);
  EXPECT_EQ(out[1].key, "camera.exposure_ms");
  EXPECT_EQ(out[1].type, "number");
  EXPECT_EQ(out[1].unit, "ms");
  EXPECT_EQ(out[1].allowed, "must be in (0, 5]");
  EXPECT_EQ(out[1].doc, "exposure time");
  EXPECT_EQ(out[1].scale, 1e-3);
  EXPECT_EQ(out[2].type, "integer");
  EXPECT_EQ(out[3].type, "vector");
  EXPECT_EQ(out[4].type, "text");
  EXPECT_EQ(out[4].allowed, "");
}

}  // namespace
}  // namespace lander
