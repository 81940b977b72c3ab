// Scenario configuration: every shipped scenario loads; defaults are valid; save/load round
// trip; bad values and unknown keys name the key; cart paths are exact.
#include <gtest/gtest.h>

#include <dirent.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "lander/sim/plant/cart_motion.h"
#include "lander/sim/scenario.h"

namespace lander::sim {
namespace {

std::vector<std::string> shipped_scenarios() {
  std::vector<std::string> out;
  DIR* d = opendir(LANDER_SCENARIOS_DIR);
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 5 && n.substr(n.size() - 5) == ".yaml") out.push_back(std::string(LANDER_SCENARIOS_DIR) + "/" + n);
  }
  closedir(d);
  return out;
}

TEST(Scenario, EveryShippedScenarioLoadsAndValidates) {
  const auto files = shipped_scenarios();
  ASSERT_GE(files.size(), 8u);  // default, flyover and the six of issue 5
  for (const auto& f : files) {
    EXPECT_NO_THROW(Scenario::load(f).validate()) << f;
  }
}

TEST(Scenario, DefaultsAreValid) { EXPECT_NO_THROW(Scenario::defaults().validate()); }

TEST(Scenario, SaveLoadRoundTrip) {
  Scenario s = Scenario::load(std::string(LANDER_SCENARIOS_DIR) + "/motion_blur.yaml");
  const std::string text = yaml_to_string(params_to_yaml(s));
  Scenario back;
  read_params(YAML::Load(text), "<saved>", back);
  EXPECT_EQ(yaml_to_string(params_to_yaml(back)), text);
  EXPECT_EQ(back.camera.blur_samples, 8);
  EXPECT_DOUBLE_EQ(back.camera.exposure_s, 0.020);
}

TEST(Scenario, BadValueNamesTheField) {
  Scenario s = Scenario::defaults();
  s.cart.path = "zigzag";
  try {
    s.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cart.path"), std::string::npos) << e.what();
  }
}

TEST(Scenario, UnknownNestedKeyNamesFileLineAndPath) {
  Scenario s;
  try {
    read_params(YAML::Load("seed: 3\nsensors:\n  gps:\n    rate: 5\n"), "x.yaml", s);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("x.yaml:4"), std::string::npos) << m;
    EXPECT_NE(m.find("sensors.gps.rate"), std::string::npos) << m;
  }
}

// ---------------------------------------------------------------- configuration errors

// The ConfigError of loading `yaml` (file name x.yaml) on top of the defaults; fails the test
// when it loads.
std::string load_error(const std::string& yaml) {
  Scenario s = Scenario::defaults();
  try {
    read_params(YAML::Load(yaml), "x.yaml", s);
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError for:\n" << yaml;
  return "";
}

// A scenario file `text` written to a temporary file; its path.
std::string temp_yaml(const std::string& text) {
  char name[] = "/tmp/lander_scenario_XXXXXX";
  const int fd = mkstemp(name);
  EXPECT_GE(fd, 0);
  if (fd >= 0) close(fd);
  std::ofstream(name) << text;
  return name;
}

struct BadValue {
  const char* yaml;
  const char* where;  ///< "x.yaml:<line>" expected in the message
  const char* key;    ///< full dotted path expected in the message
};

// One bad value per params struct of the scenario: each message names the file, the line of
// the key and its full dotted path as written in YAML (not the struct's own short name).
TEST(ScenarioConfigErrors, ValidationErrorsNameFileLineAndDottedPath) {
  const BadValue cases[] = {
      {"seed: 1\nduration_s: -4\n", "x.yaml:2", "'duration_s'"},
      {"trace_rate_hz: 0\n", "x.yaml:1", "'trace_rate_hz'"},
      {"name: a\nworld:\n  dt_ms: 9\n", "x.yaml:3", "'world.dt_ms'"},
      {"camera:\n  rate_hz: 1000\n", "x.yaml:2", "'camera.rate_hz'"},
      {"camera:\n  intrinsics:\n    fx_px: -1\n", "x.yaml:3", "'camera.intrinsics.fx_px'"},
      {"camera:\n  intrinsics:\n    width_px: 100000\n", "x.yaml:3",
       "'camera.intrinsics.width_px'"},
      {"render:\n  backend: vulkan\n", "x.yaml:2", "'render.backend'"},
      {"render: {msaa_samples: 99}\n", "x.yaml:1", "'render.msaa_samples'"},
      {"cart:\n  path: zigzag\n", "x.yaml:2", "'cart.path'"},
      {"cart:\n  stop_s: -1\n", "x.yaml:2", "'cart.stop_s'"},
      {"vehicle:\n  start_m: [0, 0, 0.1]\n", "x.yaml:2", "'vehicle.start_m'"},
      {"vehicle:\n  model:\n    rotor:\n      tau_s: -1\n", "x.yaml:4",
       "'vehicle.model.rotor.tau_s'"},
      {"vehicle:\n  model:\n    ground_effect:\n      z_min_over_R: 0.1\n", "x.yaml:4",
       "'vehicle.model.ground_effect.z_min_over_R'"},
      // Set in the file: z_min_over_R; invalid: the default z_max_over_R, at its parent's line.
      {"vehicle:\n  model:\n    ground_effect:\n      z_min_over_R: 9\n", "x.yaml:3",
       "'vehicle.model.ground_effect.z_max_over_R' (not set in this file: default value)"},
      {"vehicle:\n  control: kinematic\n  waypoints:\n    - {t_s: 2}\n    - {t_s: 1}\n",
       "x.yaml:5", "'vehicle.waypoints[1].t_s'"},
      {"sensors:\n  imu:\n    latency_ms: -1\n", "x.yaml:3", "'sensors.imu.latency_ms'"},
      {"sensors:\n  baro:\n    latency_ms: -1\n", "x.yaml:3", "'sensors.baro.latency_ms'"},
      {"sensors:\n  gps:\n    latency_ms: -1\n", "x.yaml:3", "'sensors.gps.latency_ms'"},
      {"sensors:\n  ultrasonic:\n    latency_ms: -1\n", "x.yaml:3",
       "'sensors.ultrasonic.latency_ms'"},
      {"sensors:\n  magnetometer:\n    latency_ms: -1\n", "x.yaml:3",
       "'sensors.magnetometer.latency_ms'"},
      {"wind:\n  gust_tau_s: 0\n", "x.yaml:2", "'wind.gust_tau_s'"},
      {"computer:\n  vision_latency_ms: 5000\n", "x.yaml:2", "'computer.vision_latency_ms'"},
      {"flight:\n  estimator:\n    altitude:\n      baro_std_m: 0\n", "x.yaml:4",
       "'flight.estimator.altitude.baro_std_m'"},
      {"flight:\n  estimator:\n    navigation:\n      accel_gate_frac: 2\n", "x.yaml:4",
       "'flight.estimator.navigation.accel_gate_frac'"},
      {"flight:\n  estimator:\n    sample_limits:\n      max_gyro_radps: 0\n", "x.yaml:4",
       "'flight.estimator.sample_limits.max_gyro_radps'"},
      {"flight:\n  controller:\n    tracker:\n      poly_order: 9\n", "x.yaml:4",
       "'flight.controller.tracker.poly_order'"},
      {"flight:\n  controller:\n    landing:\n      observe_frames: 0\n", "x.yaml:4",
       "'flight.controller.landing.observe_frames'"},
      {"flight:\n  controller:\n    vehicle:\n      mass_kg: -1\n", "x.yaml:4",
       "'flight.controller.vehicle.mass_kg'"},
      {"flight:\n  controller:\n    cascade:\n      pos_kp_xy: 0\n", "x.yaml:4",
       "'flight.controller.cascade.pos_kp_xy'"},
      {"flight:\n  camera:\n    fx_px: 0\n", "x.yaml:3", "'flight.camera.fx_px'"},
      {"flight:\n  estimator:\n    navigation:\n      gravity_mps2: 9.7\n", "x.yaml:4",
       "'flight.estimator.navigation.gravity_mps2'"},
      {"vehicle:\n  model:\n    mass_kg: 0\n", "x.yaml:3", "'vehicle.model.mass_kg'"},
      {"vehicle:\n  model:\n    thrust_scale: [1, 1, 1]\n", "x.yaml:3",
       "'vehicle.model.thrust_scale'"},
      {"camera:\n  mount_error_deg: [0, 45, 0]\n", "x.yaml:2", "'camera.mount_error_deg'"},
      {"cart:\n  platform_height_m: 5\n", "x.yaml:2", "'cart.platform_height_m'"},
      {"world:\n  light:\n    sun_dir: [0, 0, 1]\n", "x.yaml:3", "'world.light.sun_dir'"},
      {"faults:\n  nan_imu_duration_s: -1\n", "x.yaml:2", "'faults.nan_imu_duration_s'"},
      {"video:\n  chase_width_px: 5000\n", "x.yaml:2", "'video.chase_width_px'"},
  };
  for (const BadValue& c : cases) {
    const std::string m = load_error(c.yaml);
    EXPECT_NE(m.find(std::string(c.where) + ": "), std::string::npos) << c.yaml << " -> " << m;
    EXPECT_NE(m.find(c.key), std::string::npos) << c.yaml << " -> " << m;
  }
}

// A key left at its default can still be invalid together with one that was set: the message
// names the default key's full path and the line of its nearest parent in the file.
TEST(ScenarioConfigErrors, DefaultKeyIsLocatedAtItsNearestParent) {
  // 200 Hz leaves 5 ms a frame; the default exposure (2 ms) fits, 8 ms does not.
  const std::string m = load_error("seed: 2\ncamera:\n  exposure_ms: 8\n  rate_hz: 200\n");
  EXPECT_NE(m.find("x.yaml:3: invalid value for 'camera.exposure_ms'"), std::string::npos) << m;
  // Only rate_hz in the file: exposure_ms keeps its default, located at "camera".
  const std::string d = load_error("seed: 2\ncamera:\n  rate_hz: 1000\n");
  EXPECT_NE(d.find("'camera.rate_hz'"), std::string::npos) << d;
  const std::string v = load_error("seed: 2\nvideo:\n  camera_scale_div: 8\ncamera:\n"
                                   "  intrinsics: {width_px: 100, height_px: 100}\n");
  EXPECT_NE(v.find("x.yaml:3: invalid value for 'video.camera_scale_div'"), std::string::npos)
      << v;
}

// "a.b.c" set to `value` as a scenario file's text.
std::string yaml_setting(const std::string& path, const std::string& value) {
  std::string yaml, indent;
  std::size_t start = 0, dot;
  while ((dot = path.find('.', start)) != std::string::npos) {
    yaml += indent + path.substr(start, dot - start) + ":\n";
    indent += "  ";
    start = dot + 1;
  }
  return yaml + indent + path.substr(start) + ": " + value + "\n";
}

// The dotted path of every key of the scenario (nested structs and lists by their own key,
// not their items'), and the numeric ones, from the visitors (FieldLister).
void scenario_keys(Scenario& s, std::vector<std::string>* numeric, std::set<std::string>* all) {
  std::vector<FieldInfo> fields;
  FieldLister lister(&fields);
  visit_fields(lister, s);
  for (const FieldInfo& f : fields) {
    const std::size_t item = f.key.find("[]");
    const std::string key = item == std::string::npos ? f.key : f.key.substr(0, item);
    for (std::size_t dot = key.find('.'); dot != std::string::npos; dot = key.find('.', dot + 1)) {
      all->insert(key.substr(0, dot));
    }
    all->insert(key);
    if (item == std::string::npos && (f.type == "number" || f.type == "integer")) {
      numeric->push_back(f.key);
    }
  }
}

// Every error validate() raises names a key that exists, by its full dotted path: each
// numeric key of the scenario is set in turn to extreme values, and any keyed ConfigError
// must name a real key (so a typo or a short name in a require() fails here), with a line.
TEST(ScenarioConfigErrors, EveryValidationErrorNamesARealKey) {
  std::vector<std::string> numeric;
  std::set<std::string> all;
  Scenario defaults = Scenario::defaults();
  scenario_keys(defaults, &numeric, &all);
  ASSERT_GT(numeric.size(), 200u);
  int errors = 0;
  for (const std::string& path : numeric) {
    for (const char* value : {"-1000000000", "-1", "0", "1000000000"}) {
      Scenario s = defaults;  // a copy: Scenario::defaults() reads two files (~800 sweeps)
      try {
        read_params(YAML::Load(yaml_setting(path, value)), "x.yaml", s);
      } catch (const ConfigError& e) {
        ++errors;
        const std::string m = e.what();
        if (e.key().empty()) continue;  // a parse error (e.g. a negative seed): no key
        EXPECT_TRUE(all.count(e.key())) << "unknown key '" << e.key() << "' for " << path
                                        << " = " << value << ": " << m;
        EXPECT_EQ(m.rfind("x.yaml:", 0), 0u) << m;
      }
    }
  }
  EXPECT_GT(errors, 200);  // the sweep did reach the checks
}

// A value just outside a bounded range: the open end itself, else one past the closed end.
double outside(const Range& r) {
  if (r.lo != -range::kInf) return r.lo_open ? r.lo : r.lo - 1;
  return r.hi_open ? r.hi : r.hi + 1;
}

// Every range a visitor gives (field_spec.h) is enforced: each bounded key of the scenario
// tree (the flight configuration included; list items apart), set just outside its range,
// is refused by the loader with that key, its line and exactly the visitor's message. A
// validate() that forgot check_fields(*this) fails here.
TEST(ScenarioConfigErrors, EveryRangeInTheVisitorsIsEnforcedWithItsKey) {
  Scenario defaults = Scenario::defaults();
  std::vector<FieldInfo> fields;
  FieldLister lister(&fields);
  visit_fields(lister, defaults);
  const YAML::Node resolved = params_to_yaml(defaults);
  int bounded = 0;
  for (const FieldInfo& f : fields) {
    if (!f.range.bounded() || f.key.find("[]") != std::string::npos) continue;
    ++bounded;
    const double x = outside(f.range);
    std::ostringstream value;
    value.precision(17);
    if (f.type == "vector") {
      YAML::Node d = resolved;
      std::size_t dot;
      std::string rest = f.key;
      while ((dot = rest.find('.')) != std::string::npos) {
        d.reset(d[rest.substr(0, dot)]);
        rest = rest.substr(dot + 1);
      }
      const std::size_t n = d[rest].size();
      ASSERT_GT(n, 0u) << f.key << ": an empty default list cannot be probed";
      value << "[";
      for (std::size_t i = 0; i < n; ++i) value << (i ? ", " : "") << x;
      value << "]";
    } else {
      value << x;
    }
    Scenario s = defaults;
    try {
      read_params(YAML::Load(yaml_setting(f.key, value.str())), "x.yaml", s);
      ADD_FAILURE() << f.key << " = " << value.str() << " accepted (" << f.allowed << ")";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), f.key) << e.what();
      EXPECT_EQ(e.problem(), (f.type == "vector" ? "all entries " : "") + f.allowed) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("x.yaml:", 0), 0u) << e.what();
    }
  }
  // 308 ranges came out of the validate() bodies (the count when they moved; a floor that
  // notices a visitor losing its ranges wholesale; list items are not counted)
  EXPECT_GE(bounded, 280);
}

TEST(ScenarioConfigErrors, DuplicateKeysAreRejectedWithTheirLine) {
  const std::string top = load_error("seed: 1\nname: a\nseed: 2\n");
  EXPECT_NE(top.find("x.yaml:3"), std::string::npos) << top;
  EXPECT_NE(top.find("duplicate key 'seed'"), std::string::npos) << top;
  EXPECT_NE(top.find("line 1"), std::string::npos) << top;
  const std::string nested = load_error("camera:\n  rate_hz: 30\n  rate_hz: 60\n");
  EXPECT_NE(nested.find("x.yaml:3"), std::string::npos) << nested;
  EXPECT_NE(nested.find("'camera.rate_hz'"), std::string::npos) << nested;
  const std::string flow = load_error("cart: {path: arc, path: static}\n");
  EXPECT_NE(flow.find("'cart.path'"), std::string::npos) << flow;
}

TEST(ScenarioConfigErrors, NonScalarKeysAndNonFiniteListsAreRejected) {
  const std::string k = load_error("? [a, b]\n: 1\n");
  EXPECT_NE(k.find("x.yaml:1"), std::string::npos) << k;
  const std::string v = load_error("vehicle:\n  start_m: [0, .nan, 10]\n");
  EXPECT_NE(v.find("x.yaml:2"), std::string::npos) << v;
  EXPECT_NE(v.find("'vehicle.start_m'"), std::string::npos) << v;
}

TEST(ScenarioConfigErrors, EmptyFilesAreErrors) {
  for (const char* text : {"", "# only a comment\n\n# and another\n", "---\n", "~\n"}) {
    const std::string path = temp_yaml(text);
    try {
      Scenario::load(path);
      ADD_FAILURE() << "empty file accepted: '" << text << "'";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ":1"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
    }
    std::remove(path.c_str());
  }
  // An explicitly empty mapping is a scenario that changes nothing.
  const std::string path = temp_yaml("{}\n");
  EXPECT_NO_THROW(Scenario::load(path));
  std::remove(path.c_str());
}

// Inputs on which yaml-cpp 0.7's LoadAll never returns (found by tests/fuzz): a clean error,
// at once.
TEST(ScenarioConfigErrors, InputsThatHungTheYamlLoaderAreErrors) {
  for (const char* text : {",", "a: 1\n,\n", "8, 1.8]\nplatform_thickness_m: 0.04\n"}) {
    const std::string path = temp_yaml(text);
    EXPECT_THROW(Scenario::load(path), ConfigError) << text;
    std::remove(path.c_str());
  }
}

TEST(ScenarioConfigErrors, SecondDocumentIsAnError) {
  const std::string path = temp_yaml("seed: 1\n---\nseed: 2\n");
  try {
    Scenario::load(path);
    ADD_FAILURE() << "second document accepted";
  } catch (const ConfigError& e) {
    // The line of the '---' that starts the second document.
    EXPECT_NE(std::string(e.what()).find(path + ":2"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(Scenario, DerivedSeedsDifferPerStreamAndRepeat) {
  EXPECT_EQ(derive_seed(1, "imu"), derive_seed(1, "imu"));
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(1, "gps"));
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(2, "imu"));
}

// Tolerance for comparing closed-form cart references with numerical derivatives: the
// central difference with h = 1e-4 s has an error of order h^2 * q''' (<< 1e-5).
constexpr double kDerivTol = 1e-5;

TEST(CartMotion, ArcKeepsItsRadiusAndDerivativesAreConsistent) {
  CartMotionParams p;
  p.path = "arc";
  p.speed_mps = 1.0;
  p.turn_radius_m = 15.0;
  p.start_m = {2.0, -1.0};
  const Eigen::Vector2d centre = p.start_m + Eigen::Vector2d(0, 15.0);  // left turn, heading 0
  for (double t : {0.5, 3.0, 10.0, 40.0}) {  // t > 0: the path starts at t = 0
    const CartReference r = cart_reference(p, t);
    EXPECT_NEAR((r.q.head<2>() - centre).norm(), 15.0, 1e-9) << t;
    EXPECT_NEAR(r.qd.head<2>().norm(), 1.0, 1e-12) << t;
    const double h = 1e-4;
    const CartReference a = cart_reference(p, t + h), b = cart_reference(p, t - h);
    EXPECT_LT(((a.q - b.q) / (2 * h) - r.qd).norm(), kDerivTol) << t;
    EXPECT_LT(((a.qd - b.qd) / (2 * h) - r.qdd).norm(), kDerivTol) << t;
  }
}

TEST(CartMotion, StopAndGoStopsAndMovesOnAsConfigured) {
  CartMotionParams p;
  p.speed_profile = "stop_and_go";
  p.speed_mps = 0.8;
  p.accel_mps2 = 0.4;  // 2 s to cruise speed
  p.go_s = 4.0;
  p.stop_s = 2.0;      // period 2 + 4 + 2 + 2 = 10 s
  EXPECT_NEAR(cart_reference(p, 1.0).qd.x(), 0.4, 1e-12);   // accelerating
  EXPECT_NEAR(cart_reference(p, 4.0).qd.x(), 0.8, 1e-12);   // cruising
  EXPECT_NEAR(cart_reference(p, 9.0).qd.x(), 0.0, 1e-12);   // standing
  EXPECT_NEAR(cart_reference(p, 11.0).qd.x(), 0.4, 1e-12);  // next cycle
  // One cycle covers the ramp distances plus the cruise: 0.8 * 2 + 0.8 * 4 = 4.8 m.
  EXPECT_NEAR(cart_reference(p, 10.0).q.x(), 4.8, 1e-9);
}

}  // namespace
}  // namespace lander::sim
