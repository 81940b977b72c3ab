// The flight software's own configuration (flight/): its parameter file and how it loads.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <gtest/gtest.h>

#include "lander/flight/flight_config.h"
#include "lander/estimator/altitude_fusion.h"
#include "lander/flight/flight_stack.h"

namespace lander::flight {
namespace {

std::string yaml_of(FlightConfig c) {
  c.file.clear();  // where it came from is not a value
  return yaml_to_string(params_to_yaml(c));
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

// models/flight.yaml holds the nominal values: exactly the in-class defaults, so that a
// default changed in one place and not the other is caught. On failure the expected file
// content is `lander flight-config --defaults`.
TEST(FlightConfig, ModelsFileIsTheGeneratedDefaults) {
  std::ifstream in(default_flight_file());
  ASSERT_TRUE(in) << default_flight_file();
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), flight_defaults_yaml())
      << "regenerate: build/lander flight-config --defaults > models/flight.yaml";
}

TEST(FlightConfig, ModelsFileEqualsInClassDefaults) {
  const FlightConfig loaded = FlightConfig::load(default_flight_file());
  EXPECT_EQ(yaml_of(loaded), yaml_of(FlightConfig{}));
  EXPECT_EQ(loaded.file, default_flight_file());
}

// Given LANDER_MODELS_DIR, the default configuration files come from there (a binary away
// from its source tree, or an old binary run against its own models); a value that is not a
// directory is an error naming the variable, never a silent fall-back.
TEST(FlightConfig, ModelsDirFromTheEnvironment) {
  const std::string dir = ::testing::TempDir() + "models_env";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/flight.yaml") << "controller:\n  vehicle:\n    mass_kg: 3.25\n";
  ASSERT_EQ(setenv("LANDER_MODELS_DIR", dir.c_str(), 1), 0);
  EXPECT_EQ(models_dir(), dir);
  EXPECT_EQ(default_flight_file(), dir + "/flight.yaml");
  EXPECT_DOUBLE_EQ(FlightConfig::load(default_flight_file()).controller.vehicle.mass_kg, 3.25);
  ASSERT_EQ(setenv("LANDER_MODELS_DIR", (dir + "/flight.yaml").c_str(), 1), 0);
  try {
    models_dir();
    ADD_FAILURE() << "a file as LANDER_MODELS_DIR was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("LANDER_MODELS_DIR"), std::string::npos) << e.what();
  }
  ASSERT_EQ(unsetenv("LANDER_MODELS_DIR"), 0);
  EXPECT_EQ(models_dir(), std::string(LANDER_MODELS_DIR));
}

TEST(FlightConfig, RelativeTargetIsTakenFromTheFilesFolder) {
  const std::string path = write_temp("flight_rel.yaml", "target: sub/my_target.yaml\n");
  const FlightConfig c = FlightConfig::load(path);
  EXPECT_EQ(c.target_path, ::testing::TempDir() + "sub/my_target.yaml");
}

TEST(FlightConfig, BadValuesNameFileLineAndKey) {
  const std::string path =
      write_temp("flight_bad.yaml", "controller:\n  vehicle:\n    mass_kg: -2\n");
  try {
    FlightConfig::load(path);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("flight_bad.yaml:3"), std::string::npos) << m;
    EXPECT_NE(m.find("'controller.vehicle.mass_kg'"), std::string::npos) << m;
  }
}

// One belief about gravity: the navigation's and the vehicle model's must agree.
TEST(FlightConfig, GravityBeliefsMustAgree) {
  FlightConfig c;
  c.estimator.navigation.gravity_mps2 = 9.78;
  EXPECT_THROW(c.validate(), ConfigError);
  c.controller.vehicle.gravity_mps2 = 9.78;
  EXPECT_NO_THROW(c.validate());
}

TEST(FlightConfig, ResolveFlightFile) {
  EXPECT_EQ(resolve_flight_file("", "/a/b/s.yaml"), default_flight_file());
  EXPECT_EQ(resolve_flight_file("f.yaml", "/a/b/s.yaml"), "/a/b/f.yaml");
  EXPECT_EQ(resolve_flight_file("../f.yaml", "/a/b/s.yaml"), "/a/f.yaml");
  EXPECT_EQ(resolve_flight_file("/x/f.yaml", "/a/b/s.yaml"), "/x/f.yaml");
}

TEST(FlightStack, MissingTargetFileIsAConfigError) {
  FlightConfig c;
  c.target_path = ::testing::TempDir() + "no_such_target.yaml";
  EXPECT_THROW(FlightStack{c}, ConfigError);
}

// The stack holds exactly the configuration it was built from.
TEST(FlightStack, KeepsItsConfiguration) {
  FlightConfig c;
  c.camera.fx_px = 700;
  c.estimator.altitude.platform_height_m = 1.1;
  const FlightStack fs(c);
  EXPECT_EQ(fs.config().camera.fx_px, 700);
  EXPECT_EQ(fs.config().estimator.altitude.platform_height_m, 1.1);
  EXPECT_FALSE(fs.altitude_started());
  EXPECT_FALSE(fs.nav_state().valid);
}

// With estimator.vision.rolling_shutter_row_time a pose in a rolling-shutter frame is stamped
// at the mid-exposure of the row its platform centre projects to (the flight software's own
// camera model): a centre three quarters down the image was read 3/4 of the readout after the
// first row. Off, or with a global shutter, or without a pose: the middle row's (mid()).
// On by default (the paired campaign of docs/results/camera.md).
TEST(FlightStack, RollingShutterPosesTakeTheirRowsTime) {
  FlightConfig c;  // the option is on by default
  const FlightStack fs(c);
  const int rows = c.camera.height_px;
  ExposureInterval e;
  e.t_start_s = 1.0;
  e.readout_s = 0.030;
  e.t_end_s = 1.0 + 0.030 + 0.002;
  PlatformObservation obs;
  obs.detected = true;
  const double z = 5.0, v = 0.75 * rows;
  obs.X_CP = Eigen::Isometry3d::Identity();
  obs.X_CP.translation() = Eigen::Vector3d(0.3, (v - c.camera.cy_px) * z / c.camera.fy_px, z);
  EXPECT_NEAR(fs.observation_time(e, obs, rows), 1.0 + 0.75 * 0.030 + 0.001, 1e-12);
  ExposureInterval global = e;
  global.readout_s = 0.0;
  global.t_end_s = 1.002;
  EXPECT_EQ(fs.observation_time(global, obs, rows), global.mid());
  PlatformObservation none = obs;
  none.detected = false;
  EXPECT_EQ(fs.observation_time(e, none, rows), e.mid());
  FlightConfig off;
  off.estimator.vision.rolling_shutter_row_time = false;
  const FlightStack plain(off);
  EXPECT_EQ(plain.observation_time(e, obs, rows), e.mid());
}

// The flight software's belief of its frames' timing (flight.camera, issue 54). A driver that
// stamps on arrival reports the exposure 40 ms late; believing a 40 ms stamp delay puts it
// back where it was. A believed readout replaces the reported one with each row's exposure
// kept. The defaults take the driver's interval as it is (bit for bit).
TEST(FlightCamera, BelievedExposureFollowsTheStampDelayAndReadout) {
  constexpr double kExact = 1e-12;  // sums of a few doubles near 1 s
  ExposureInterval truth;
  truth.t_start_s = 1.0;
  truth.readout_s = 0.030;
  truth.t_end_s = 1.0 + 0.030 + 0.002;  // 2 ms rows
  ExposureInterval reported = truth;   // stamped on arrival, 40 ms after the exposure end
  reported.t_start_s += 0.040;
  reported.t_end_s += 0.040;
  const double stamp = reported.t_end_s;

  const FlightCamera defaults;
  const ExposureInterval same = defaults.believed_exposure(reported, stamp);
  EXPECT_EQ(same.t_start_s, reported.t_start_s);
  EXPECT_EQ(same.t_end_s, reported.t_end_s);
  EXPECT_EQ(same.readout_s, reported.readout_s);

  FlightCamera delayed;
  delayed.stamp_delay_s = 0.040;
  const ExposureInterval back = delayed.believed_exposure(reported, stamp);
  EXPECT_NEAR(back.t_start_s, truth.t_start_s, kExact);
  EXPECT_NEAR(back.t_end_s, truth.t_end_s, kExact);
  EXPECT_EQ(back.readout_s, truth.readout_s);

  FlightCamera global;  // believes a global shutter: the rows' 2 ms, ending at the stamp
  global.readout_s = 0.0;
  const ExposureInterval g = global.believed_exposure(reported, stamp);
  EXPECT_EQ(g.readout_s, 0.0);
  EXPECT_EQ(g.t_end_s, reported.t_end_s);
  EXPECT_NEAR(g.row_exposure_s(), 0.002, kExact);
  EXPECT_NEAR(g.mid(), reported.t_end_s - 0.001, kExact);
}

// Through the stack: a frame without a target is stamped at the believed exposure's middle
// (flight.camera.stamp_delay_ms 40 on a driver stamping 40 ms after the exposure end: the
// true middle).
TEST(FlightStack, FramesAreTimedByTheBelievedExposure) {
  constexpr double kExact = 1e-12;
  FlightConfig c;
  c.camera.stamp_delay_s = 0.040;
  FlightStack fs(c);
  std::vector<std::uint8_t> grey(static_cast<std::size_t>(c.camera.width_px) * c.camera.height_px * 3, 128);
  CameraFrameIn in;
  in.exposure.t_start_s = 1.040;
  in.exposure.t_end_s = 1.042;
  in.stamp_s = 1.042;
  in.image = {c.camera.width_px, c.camera.height_px, 3 * c.camera.width_px, grey.data()};
  auto job = fs.begin_frame(in);
  job->process();
  const auto& r = static_cast<const RingFrameJob&>(*job).result();
  EXPECT_FALSE(r.obs.detected);
  EXPECT_NEAR(r.obs.t_s, 1.001, kExact);
}

// Given a vehicle at rest 8 m up whose GPS reads 2 m (a degraded receiver's slowly varying
// height error) and a barometer that reads true, when the stack has run 5 s, then with
// navigation.height_from_altitude_fusion the controller's state carries the altitude fusion's
// height and climb rate exactly, and without it the navigation filter's GPS-only height,
// which is lower: the fusion also weighs the barometer (with its 3 m bias prior it still
// takes much of the disagreement as baro bias in 5 s, so only kApart_m is asserted).
TEST(FlightStack, ControllerFliesOnTheFusedHeight) {
  constexpr double kApart_m = 0.2;
  auto run = [](bool fused) {
    FlightConfig c;
    c.estimator.navigation.height_from_altitude_fusion = fused;
    auto fs = std::make_unique<FlightStack>(c);
    const double g = c.estimator.navigation.gravity_mps2;
    for (int k = 0; k <= 5000; ++k) {  // IMU at 1 kHz, baro at 50 Hz, GPS at 5 Hz
      const double t = k * 1e-3;
      ImuSample imu;
      imu.t_s = t;
      imu.accel_B_mps2 = Eigen::Vector3d(0.0, 0.0, g);
      fs->on_imu(imu);
      if (k % 20 == 0) {
        BaroSample b;
        b.t_s = t;
        b.pressure_pa = isa_pressure_pa(c.estimator.altitude.baro_origin_msl_m + 8.0);
        fs->on_baro(b);
      }
      if (k % 200 == 0) {
        GpsSample gps;
        gps.t_s = t;
        gps.p_W_m = Eigen::Vector3d(0.0, 0.0, 2.0);
        fs->on_gps(gps);
      }
    }
    return fs;
  };
  const auto on = run(true), off = run(false);
  ASSERT_TRUE(on->nav_state().valid && on->altitude_started());
  EXPECT_EQ(on->nav_state().p_W_m.z(), on->altitude().z_W_m);
  EXPECT_EQ(on->nav_state().v_W_mps.z(), on->altitude().vz_W_mps);
  EXPECT_GT(on->nav_state().p_W_m.z() - off->nav_state().p_W_m.z(), kApart_m);
  EXPECT_NEAR(off->nav_state().p_W_m.z(), 2.0, 0.5) << "the GPS-only channel";
  // The horizontal channels are the navigation filter's either way.
  EXPECT_EQ(on->nav_state().p_W_m.head<2>(), off->nav_state().p_W_m.head<2>());
}

}  // namespace
}  // namespace lander::flight
