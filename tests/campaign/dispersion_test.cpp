// Dispersions are parsed once into typed distributions (Dispersion::parse) and a draw only
// draws (Dispersion::sample). The draws are those of the code before the typed distributions
// (commit ddf2ad3, which parsed the YAML again at every draw): the expected texts below are
// what `lander campaign plan` printed there for run tiny-0000 of this campaign (17
// significant digits, so equal text is the same double).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <variant>

#include "lander/campaign/campaign.h"

namespace lander::campaign {
namespace {

namespace fs = std::filesystem;
const std::string kTiny = std::string(LANDER_TESTS_DIR) + "/campaign/data/tiny.yaml";

const char* kEveryKind =
    "seed: 12345\n"
    "scenarios:\n"
    "  - {file: TINY, runs: 1}\n"
    "  - {file: TINY, id: second, runs: 1, first_seed: 100, dispersions: {vehicle.start_m: {polar: "
    "{radius: [1, 4], direction_deg: [10, 80], center: [-3, 1], z: [3, 6], uniform_in: area}}}}\n"
    "dispersions:\n"
    "  cart.speed_mps: {normal: {mean: 0.8, std: 0.5}, min: 0.1, max: 1.4}\n"
    "  vehicle.start_m: {normal: {mean: [-2, 0, 4], std: [1, 1, 0.5]}, min: [-4, -2, 3]}\n"
    "  wind.steady_W_mps: {polar: {radius: [0, 3], z: 0.25}}\n"
    "  cart.path: {choice: [straight, arc, static], weights: [1, 2.5, 0.5]}\n"
    "  world.ground_seed: {integer: [3, 17]}\n"
    "  vehicle.model.mass_kg: {loguniform: [2.0, 3.5]}\n"
    "  camera.mount_offset_m: {uniform: [[-0.01, -0.02, -0.03], [0.01, 0.02, 0.0]]}\n"
    "  camera.mount_error_deg: {integer: [-2, 2]}\n"
    "  wind.gust_tau_s: {constant: 2.5}\n"
    "  sensors.imu.misalignment_deg: {choice: [[0, 0, 0], [0.5, -0.5, 1]]}\n";

Campaign load_every_kind() {
  std::string text = kEveryKind;
  for (std::size_t at; (at = text.find("TINY")) != std::string::npos;) text.replace(at, 4, kTiny);
  const fs::path f = fs::temp_directory_path() / ("lander_dispersion_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(f) << text;
  Campaign c = Campaign::load(f.string());
  fs::remove(f);
  return c;
}

std::map<std::string, std::string> columns(const PlannedRun& r) {
  std::map<std::string, std::string> out;
  for (const auto& [k, v] : r.sampled) {
    for (const auto& [col, text] : flatten_value(k, v)) out[col] = text;
  }
  return out;
}

TEST(Dispersion, LoadParsesEachKindIntoItsTypedDistribution) {
  const Campaign c = load_every_kind();
  std::map<std::string, std::size_t> kind;
  for (const Dispersion& d : c.dispersions) kind[d.key] = d.distribution.index();
  EXPECT_TRUE(std::holds_alternative<NormalDistribution>(c.dispersions.at(0).distribution));
  EXPECT_EQ(kind.at("cart.speed_mps"), 3u);                // normal
  EXPECT_EQ(kind.at("wind.steady_W_mps"), 5u);             // polar
  EXPECT_EQ(kind.at("cart.path"), 4u);                     // choice
  EXPECT_EQ(kind.at("wind.gust_tau_s"), 4u);               // constant: a choice of one
  EXPECT_EQ(kind.at("world.ground_seed"), 2u);             // integer
  EXPECT_EQ(kind.at("vehicle.model.mass_kg"), 1u);         // loguniform
  EXPECT_EQ(kind.at("camera.mount_offset_m"), 0u);         // uniform
  const auto& n = std::get<NormalDistribution>(c.dispersions.at(1).distribution);
  EXPECT_EQ(n.mean, (std::vector<double>{-2, 0, 4}));
  EXPECT_EQ(n.min, (std::vector<double>{-4, -2, 3}));
  EXPECT_EQ(n.max[0], INFINITY);  // no max: untruncated above
  const auto& p = std::get<PolarDistribution>(c.scenarios.at(1).dispersions.at(0).distribution);
  EXPECT_TRUE(p.uniform_in_area && p.z_drawn);
  EXPECT_EQ(p.components, 3u);
  const auto& w = std::get<ChoiceDistribution>(c.dispersions.at(3).distribution);
  EXPECT_EQ(w.total_weight, 4.0);
}

TEST(Dispersion, DrawsAreThoseOfTheCodeBeforeTheTypedDistributions) {
  const std::vector<PlannedRun> plan = make_plan(load_every_kind());
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_EQ(plan[0].seed, 5556585914524682u);
  const std::map<std::string, std::string> expect = {
      {"camera.mount_error_deg[0]", "-2"},
      {"camera.mount_error_deg[1]", "1"},
      {"camera.mount_error_deg[2]", "-2"},
      {"camera.mount_offset_m[0]", "-0.0050154163907398623"},
      {"camera.mount_offset_m[1]", "0.017902500972100454"},
      {"camera.mount_offset_m[2]", "-0.012836084665983776"},
      {"cart.path", "arc"},
      {"cart.speed_mps", "0.44081104965271323"},
      {"sensors.imu.misalignment_deg[0]", "0.5"},
      {"sensors.imu.misalignment_deg[1]", "-0.5"},
      {"sensors.imu.misalignment_deg[2]", "1"},
      {"vehicle.model.mass_kg", "3.2252063647347224"},
      {"vehicle.start_m[0]", "-3.1069120143403071"},
      {"vehicle.start_m[1]", "-1.2440197572837042"},
      {"vehicle.start_m[2]", "3.9461370436413765"},
      {"wind.gust_tau_s", "2.5"},
      {"wind.steady_W_mps[0]", "0.56548021726541498"},
      {"wind.steady_W_mps[1]", "-2.4591810136295318"},
      {"wind.steady_W_mps[2]", "0.25"},
      {"world.ground_seed", "9"}};
  EXPECT_EQ(columns(plan[0]), expect);
  // The entry's own polar dispersion of vehicle.start_m (uniform in area, z drawn).
  const auto second = columns(plan[1]);
  EXPECT_EQ(second.at("vehicle.start_m[0]"), "-0.28829523910851718");
  EXPECT_EQ(second.at("vehicle.start_m[1]"), "3.2261730262142074");
  EXPECT_EQ(second.at("vehicle.start_m[2]"), "5.8660905502313012");
}

TEST(Dispersion, SampleIsAFunctionOfTheStreamSeedAlone) {
  const Campaign c = load_every_kind();
  for (const Dispersion& d : c.dispersions) {
    EXPECT_EQ(YAML::Dump(d.sample(7)), YAML::Dump(d.sample(7))) << d.key;
  }
  // A draw is a copy: changing it leaves the distribution's options as they were.
  const Dispersion& choice = c.dispersions.at(9);
  ASSERT_EQ(choice.key, "sensors.imu.misalignment_deg");
  YAML::Node v = choice.sample(3);
  v[0] = 99;
  for (const YAML::Node& o : std::get<ChoiceDistribution>(choice.distribution).options) {
    EXPECT_NE(o[0].as<double>(), 99.0);
  }
}

}  // namespace
}  // namespace lander::campaign
