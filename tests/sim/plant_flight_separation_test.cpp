// The plant and the flight software apart (issue 10): the scenario's plant keys describe the
// truth and never reach the flight configuration; the flight configuration never changes the
// plant. And the plant truths do reach the simulated world.
#include <unistd.h>

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "lander/sim/plant/plant.h"
#include "lander/sim/scenario.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {
namespace {

std::string temp_yaml(const std::string& dir_prefix, const std::string& name, const std::string& text) {
  char dir[] = "/tmp/lander_sep_XXXXXX";
  const char* d = mkdtemp(dir);
  EXPECT_NE(d, nullptr);
  const std::string path = std::string(d) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string yaml_of(const flight::FlightConfig& c) { return yaml_to_string(params_to_yaml(c)); }

// Everything of a scenario but its flight configuration and name/description.
std::string plant_yaml_of(Scenario s) {
  s.flight = flight::FlightConfig{};
  return yaml_to_string(params_to_yaml(s));
}

// Every plant truth a campaign may disperse, set far from nominal.
const char* kPlantChanges = R"(name: plant_changed
vehicle:
  model:
    mass_kg: 4.6
    inertia_kgm2: [0.1, 0.11, 0.2]
    thrust_scale: [1, 1, 1, 1, 1, 0.9]
    tau_scale: [1, 1.5, 1, 1, 1, 1]
    rotor: {kT: 2.1e-5}
camera:
  intrinsics: {fx_px: 652.8, fy_px: 652.8, k1: -0.08}
  mount_error_deg: [1, 0, 0]
  gain: 0.7
cart:
  platform_height_m: 0.9
sensors:
  imu: {gravity_mps2: 9.79, misalignment_deg: [0.5, 0, 0]}
  magnetometer: {field_W_uT: [20, 5, -40], declination_deg: 8}
world:
  light: {sun_intensity: 0.9}
render:
  shadows: true
)";

TEST(PlantFlightSeparation, PlantTruthsNeverReachTheFlightConfiguration) {
  const Scenario nominal = Scenario::load(temp_yaml("", "n.yaml", "name: nominal\n"));
  const Scenario changed = Scenario::load(temp_yaml("", "c.yaml", kPlantChanges));
  // The plant did change ...
  EXPECT_EQ(changed.vehicle.model.mass_kg, 4.6);
  EXPECT_EQ(changed.camera.intrinsics.fx_px, 652.8);
  EXPECT_EQ(changed.cart.platform_height_m, 0.9);
  EXPECT_NE(plant_yaml_of(changed), plant_yaml_of(nominal));
  // ... and what the flight software believes did not.
  EXPECT_EQ(yaml_of(changed.flight), yaml_of(nominal.flight));
  EXPECT_EQ(changed.flight.controller.vehicle.mass_kg, 4.0);
  EXPECT_EQ(changed.flight.camera.fx_px, 640.0);
  EXPECT_EQ(changed.flight.camera.k1, 0.0);
  EXPECT_EQ(changed.flight.estimator.altitude.platform_height_m, 0.8);
  EXPECT_EQ(changed.flight.estimator.navigation.gravity_mps2, 9.81);
  EXPECT_EQ(changed.flight.estimator.navigation.mag_field_W_uT, Eigen::Vector3d(22.0, 2.0, -42.0));
}

TEST(PlantFlightSeparation, FlightConfigurationNeverChangesThePlant) {
  const Scenario nominal = Scenario::load(temp_yaml("", "n.yaml", "name: nominal\n"));
  const Scenario believed = Scenario::load(temp_yaml("", "b.yaml", R"(name: nominal
flight:
  camera: {fx_px: 700, k1: -0.1}
  mount: {rpy_BC_deg: [181, 0, -90]}
  estimator:
    altitude: {platform_height_m: 1.0}
    navigation: {mag_field_W_uT: [10, 10, -40], gravity_mps2: 9.8}
  controller:
    vehicle: {mass_kg: 5, gravity_mps2: 9.8}
)"));
  EXPECT_EQ(plant_yaml_of(believed), plant_yaml_of(nominal));
  EXPECT_EQ(believed.flight.camera.fx_px, 700);
  EXPECT_EQ(believed.flight.controller.vehicle.mass_kg, 5);
}

// flight.file names another parameter file (relative to the scenario); the scenario's own
// flight keys go on top of it.
TEST(PlantFlightSeparation, FlightFileThenScenarioOverrides) {
  const std::string dir_file = temp_yaml("", "my_flight.yaml",
                                         "camera: {fx_px: 650}\ncontroller: {cascade: {pos_kp_xy: 1.0}}\n");
  const std::string dir = dir_file.substr(0, dir_file.rfind('/'));
  std::ofstream(dir + "/s.yaml") << "name: s\nflight:\n  file: my_flight.yaml\n  controller: {cascade: {pos_kp_xy: 1.1}}\n";
  const Scenario s = Scenario::load(dir + "/s.yaml");
  EXPECT_EQ(s.flight.file, dir_file);
  EXPECT_EQ(s.flight.camera.fx_px, 650);                       // from the file
  EXPECT_EQ(s.flight.controller.cascade.pos_kp_xy, 1.1);       // the scenario wins
  // The resolved scenario reloads to the same configuration from anywhere.
  const std::string resolved = yaml_to_string(params_to_yaml(s));
  std::ofstream("/tmp/lander_sep_resolved.yaml") << resolved;
  const Scenario again = Scenario::load("/tmp/lander_sep_resolved.yaml");
  EXPECT_EQ(yaml_of(again.flight), yaml_of(s.flight));
  std::remove("/tmp/lander_sep_resolved.yaml");
}

TEST(PlantFlightSeparation, MissingFlightFileNamesTheScenarioLine) {
  const std::string path = temp_yaml("", "s.yaml", "name: s\nflight:\n  file: nowhere.yaml\n");
  try {
    Scenario::load(path);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("s.yaml:3"), std::string::npos) << m;
    EXPECT_NE(m.find("flight.file"), std::string::npos) << m;
    EXPECT_NE(m.find("nowhere.yaml"), std::string::npos) << m;
  }
}

TEST(PlantFlightSeparation, OldTopLevelKeysSayWhereTheyMoved) {
  const std::string path = temp_yaml("", "s.yaml", "name: s\ncontroller:\n  cascade: {pos_kp_xy: 1}\n");
  try {
    Scenario::load(path);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("s.yaml:2"), std::string::npos) << m;
    EXPECT_NE(m.find("flight.controller"), std::string::npos) << m;
  }
}

// The plant truths reach the MuJoCo world (and only it).
TEST(PlantTruth, AppliedToTheWorld) {
  const Scenario nominal = Scenario::load(temp_yaml("", "n.yaml", "name: nominal\n"));
  const Scenario changed = Scenario::load(temp_yaml("", "c.yaml", kPlantChanges));
  World wn(nominal.world, nominal.camera.intrinsics), wc(changed.world, changed.camera.intrinsics);
  apply_plant_truth(nominal, wn);
  apply_plant_truth(changed, wc);
  const int vb = wc.vehicle_body();
  // Tolerance: exact values written into mjModel, derived constants recomputed by MuJoCo.
  EXPECT_NEAR(wn.model()->body_subtreemass[vb], 4.0, 1e-12);
  EXPECT_NEAR(wc.model()->body_subtreemass[vb], 4.6, 1e-12);
  EXPECT_NEAR(wc.model()->body_inertia[3 * vb + 1], 0.11, 1e-12);
  // Rendering constants stay the model's: the near plane (znear x extent) must not move, or
  // the platform vanishes from a close camera (mj_setConst recomputes the extent).
  EXPECT_EQ(wc.model()->stat.extent, wn.model()->stat.extent);
  EXPECT_EQ(wc.model()->vis.map.znear, wn.model()->vis.map.znear);
  EXPECT_NEAR(wn.X_WP().translation().z(), 0.80, 1e-9);
  EXPECT_NEAR(wc.X_WP().translation().z(), 0.90, 1e-9);
  // Camera: rotated 1 deg about B's x relative to the nominal mount (same vehicle pose).
  const Eigen::Matrix3d R_BC_n = wn.X_WB().linear().transpose() * wn.X_WC().linear();
  const Eigen::Matrix3d R_BC_c = wc.X_WB().linear().transpose() * wc.X_WC().linear();
  const Eigen::AngleAxisd d(R_BC_c * R_BC_n.transpose());
  EXPECT_NEAR(d.angle() * 180 / M_PI, 1.0, 1e-6);
  EXPECT_NEAR(std::abs(d.axis().x()), 1.0, 1e-6);
  const int sun = mj_name2id(wc.model(), mjOBJ_LIGHT, "sun");
  EXPECT_EQ(wc.model()->light_castshadow[sun], 1);
  EXPECT_EQ(wn.model()->light_castshadow[sun], 0);
}

}  // namespace
}  // namespace lander::sim
