// Campaign files: loading, dispersions, determinism of the plan, and errors with file:line.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "lander/campaign/campaign.h"
#include "lander/core/params_io.h"
#include "lander/sim/scenario.h"

namespace lander::campaign {
namespace {

namespace fs = std::filesystem;
const std::string kData = std::string(LANDER_TESTS_DIR) + "/campaign/data";

// Writes a campaign file next to the test scenario (paths in it are relative to it).
std::string write_campaign(const std::string& name, const std::string& text) {
  const std::string dir = fs::temp_directory_path() / ("lander_campaign_file_" + std::to_string(getpid()));
  fs::create_directories(dir);
  fs::copy_file(kData + "/tiny.yaml", dir + "/tiny.yaml", fs::copy_options::overwrite_existing);
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// The message of the ConfigError `f` throws ("" when it does not throw).
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

double as_d(const YAML::Node& n) { return n.as<double>(); }

const YAML::Node& sampled(const PlannedRun& r, const std::string& key) {
  for (const auto& kv : r.sampled) {
    if (kv.first == key) return kv.second;
  }
  throw std::runtime_error("run " + r.id + " has no sampled " + key);
}

TEST(CampaignFile, ShippedCampaignsLoadAndPlan) {
  // Every campaign file shipped under campaigns/ loads, validates and plans.
  std::set<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(LANDER_CAMPAIGNS_DIR)) {
    if (e.path().extension() == ".yaml") names.insert(e.path().filename().string());
  }
  EXPECT_TRUE(names.count("smoke.yaml") && names.count("envelope.yaml") && names.count("mismatch.yaml"));
  for (const std::string& name : names) {
    const Campaign c = Campaign::load(std::string(LANDER_CAMPAIGNS_DIR) + "/" + name);
    const auto plan = make_plan(c);
    EXPECT_FALSE(plan.empty()) << name;
    if (name == "envelope.yaml") {
      EXPECT_GE(plan.size(), 200u);
    }
  }
}

// The plant-mismatch campaign disperses plant truths only: nothing it samples reaches the
// flight software's configuration (flight.*), and the focal lengths stay within the 0.3 % of
// the nominal 640 px it states (a pixel aspect error beyond ~0.6 % breaks close-range vision:
// README).
TEST(CampaignFile, MismatchCampaignDispersesThePlantOnly) {
  const Campaign c = Campaign::load(std::string(LANDER_CAMPAIGNS_DIR) + "/mismatch.yaml");
  const auto plan = make_plan(c);
  ASSERT_EQ(plan.size(), 24u);
  for (const PlannedRun& r : plan) {
    for (const auto& kv : r.sampled) EXPECT_NE(kv.first.rfind("flight.", 0), 0u) << kv.first;
    for (const char* key : {"camera.intrinsics.fx_px", "camera.intrinsics.fy_px"}) {
      const double f = as_d(sampled(r, key));
      EXPECT_LE(std::abs(f / 640.0 - 1.0), 0.003 + 1e-12) << r.id << " " << key;
    }
    EXPECT_GT(as_d(sampled(r, "vehicle.model.mass_kg")), 0.0);
  }
}

TEST(CampaignFile, PlanIsDeterministicAndWithinTheDistributions) {
  const Campaign c = Campaign::load(kData + "/tiny_campaign.yaml");
  const auto a = make_plan(c), b = make_plan(c);
  ASSERT_EQ(a.size(), 5u);
  std::set<std::string> ids;
  std::set<std::uint64_t> seeds;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_EQ(a[i].seed, b[i].seed);
    EXPECT_EQ(run_scenario_yaml(a[i]), run_scenario_yaml(b[i]));
    ids.insert(a[i].id);
    seeds.insert(a[i].seed);
    const double v = as_d(sampled(a[i], "cart.speed_mps"));
    EXPECT_GE(v, 0.0);
    EXPECT_LE(v, 1.5);
    const YAML::Node p = sampled(a[i], "vehicle.start_m");
    ASSERT_EQ(p.size(), 3u);
    EXPECT_GE(as_d(p[0]), -4.0);
    EXPECT_LE(as_d(p[0]), 0.0);
    EXPECT_GE(as_d(p[2]), 3.0);
    EXPECT_LE(as_d(p[2]), 5.0);
    const YAML::Node w = sampled(a[i], "wind.steady_W_mps");
    EXPECT_LE(std::hypot(as_d(w[0]), as_d(w[1])), 3.0 + 1e-12);
    EXPECT_EQ(as_d(w[2]), 0.0);
  }
  EXPECT_EQ(ids.size(), a.size());
  EXPECT_EQ(seeds.size(), a.size());
  EXPECT_EQ(a[0].id, "tiny-0000");
  EXPECT_EQ(a[3].id, "tiny_arc-0000");
  EXPECT_EQ(sampled(a[3], "cart.path").as<std::string>(), "arc");  // the entry's own dispersion
}

// The run's scenario is what the run loads: the sampled values are in force in it, it passes
// validate(), and writing it back gives the same text (so a rerun from
// scenario.resolved.yaml reproduces the run).
TEST(CampaignFile, RunScenarioCarriesTheSampledValuesAndRoundTrips) {
  const auto plan = make_plan(Campaign::load(kData + "/tiny_campaign.yaml"));
  for (const PlannedRun& r : plan) {
    const std::string text = run_scenario_yaml(r);
    sim::Scenario s = sim::Scenario::defaults();
    read_params(YAML::Load(text), r.id, s);
    EXPECT_EQ(s.seed, r.seed);
    EXPECT_EQ(s.cart.speed_mps, as_d(sampled(r, "cart.speed_mps")));
    EXPECT_EQ(s.vehicle.start_p_W_m.x(), as_d(sampled(r, "vehicle.start_m")[0]));
    EXPECT_EQ(s.duration_s, 3.0);  // the scenario file's own keys stay
    EXPECT_EQ(yaml_to_string(params_to_yaml(s)), text);
  }
}

TEST(CampaignFile, SampledValueDependsOnlyOnSeedScenarioIndexAndKey) {
  const std::string one = write_campaign("one.yaml",
                                         "seed: 5\nscenarios: [{file: tiny.yaml, runs: 3}]\n"
                                         "dispersions:\n  cart.speed_mps: {uniform: [0, 1]}\n");
  const std::string two = write_campaign("two.yaml",
                                         "seed: 5\nscenarios: [{file: tiny.yaml, runs: 5}]\n"
                                         "dispersions:\n  wind.gust_tau_s: {uniform: [1, 3]}\n"
                                         "  cart.speed_mps: {uniform: [0, 1]}\n");
  const std::string other_seed = write_campaign("three.yaml",
                                                "seed: 6\nscenarios: [{file: tiny.yaml, runs: 3}]\n"
                                                "dispersions:\n  cart.speed_mps: {uniform: [0, 1]}\n");
  const auto a = make_plan(Campaign::load(one));
  const auto b = make_plan(Campaign::load(two));
  const auto c = make_plan(Campaign::load(other_seed));
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(as_d(sampled(a[i], "cart.speed_mps")), as_d(sampled(b[i], "cart.speed_mps")));
    EXPECT_EQ(a[i].seed, b[i].seed);
    EXPECT_NE(as_d(sampled(a[i], "cart.speed_mps")), as_d(sampled(c[i], "cart.speed_mps")));
  }
}

// Choice weights: 1000 draws of {a: 3, b: 1} give a share of b within 4 standard errors of
// 0.25 (standard error sqrt(0.25 * 0.75 / 1000) = 0.0137).
TEST(CampaignFile, ChoiceWeightsAreHonoured) {
  const std::string f = write_campaign("w.yaml",
                                       "seed: 9\nscenarios: [{file: tiny.yaml, runs: 1000}]\n"
                                       "dispersions:\n  cart.path: {choice: [straight, static], weights: [3, 1]}\n");
  const auto plan = make_plan(Campaign::load(f));
  int b = 0;
  for (const auto& r : plan) b += sampled(r, "cart.path").as<std::string>() == "static";
  EXPECT_NEAR(b / 1000.0, 0.25, 4 * 0.0137);
}

struct BadCase {
  const char* what;
  const char* dispersion_line;  // under `dispersions:`
  const char* expect;           // in the message, besides file:line
};

TEST(CampaignFile, BadDispersionsNameFileLineAndKey) {
  const BadCase cases[] = {
      {"unknown key", "  cart.speedd: {uniform: [0, 1]}", "unknown scenario key 'cart.speedd'"},
      {"section", "  cart: {uniform: [0, 1]}", "is a section"},
      {"low > high", "  cart.speed_mps: {uniform: [2, 1]}", "low 2 > high 1"},
      {"no distribution", "  cart.speed_mps: {mean: 1}", "unknown distribution key 'mean'"},
      {"two distributions", "  cart.speed_mps: {uniform: [0, 1], constant: 1}", "give one distribution"},
      {"shape", "  vehicle.start_m: {uniform: [[0, 0], [1, 1]]}", "expected 3 values"},
      {"string numeric", "  cart.path: {uniform: [0, 1]}", "is not a number"},
      {"choice shape", "  vehicle.start_m: {choice: [1, 2]}", "shape"},
      {"negative std", "  cart.speed_mps: {normal: {mean: 1, std: -1}}", "std must be >= 0"},
      {"improbable truncation", "  cart.speed_mps: {normal: {mean: 0, std: 0.001}, min: 3, max: 4}",
       "too improbable"},
      {"validate() rejects", "  cart.speed_mps: {uniform: [16, 17]}", "which the scenario rejects"},
      {"seed", "  seed: {uniform: [0, 1]}", "cannot be dispersed"},
  };
  for (const BadCase& c : cases) {
    const std::string f = write_campaign("bad.yaml",
                                         std::string("seed: 1\nscenarios: [{file: tiny.yaml, runs: 2}]\n"
                                                     "dispersions:\n") + c.dispersion_line + "\n");
    const std::string msg = error_of([&] { make_plan(Campaign::load(f)); });
    EXPECT_NE(msg.find(f + ":4"), std::string::npos) << c.what << ": " << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.what << ": " << msg;
  }
}

TEST(CampaignFile, BadEntriesAndTopLevelKeys) {
  const std::pair<const char*, const char*> cases[] = {
      {"seed: 1\nscenarioz: []\n", "unknown key 'scenarioz'"},
      {"seed: 1\nscenarios: []\n", "non-empty list"},
      {"seed: 1\nscenarios: [{file: nope.yaml, runs: 1}]\n", "not found"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 0}]\n", "runs: must be in"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: x}]\n", "expected a whole number"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1, rnus: 2}]\n", "unknown scenario entry key 'rnus'"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1}, {file: tiny.yaml, runs: 1}]\n", "used twice"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1, id: \"a/b\"}]\n", "must be 1-64 letters"},
      {"seed: -3\nscenarios: [{file: tiny.yaml, runs: 1}]\n", "seed: expected a non-negative integer"},
      // A repeated key, which yaml-cpp would let pass with the first value: refused with both lines.
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1}]\nseed: 2\n", ":3: duplicate key 'seed' (first at line 1)"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1, runs: 2}]\n", "duplicate key 'scenarios[0].runs'"},
      {"seed: 1\nscenarios: [{file: tiny.yaml, runs: 1}]\ndispersions:\n  cart.speed_mps: {uniform: [0, 1]}\n"
       "  cart.speed_mps: {uniform: [1, 2]}\n", ":5: duplicate key 'dispersions.cart.speed_mps' (first at line 4)"},
  };
  for (const auto& [text, expect] : cases) {
    const std::string f = write_campaign("bad2.yaml", text);
    const std::string msg = error_of([&] { make_plan(Campaign::load(f)); });
    EXPECT_NE(msg.find(f + ":"), std::string::npos) << text << ": " << msg;
    EXPECT_NE(msg.find(expect), std::string::npos) << text << ": " << msg;
  }
}

}  // namespace
}  // namespace lander::campaign
