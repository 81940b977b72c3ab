// The flight software's sample screen and its filters never throw on a bad sample: NaN and
// absurd IMU / barometer / GPS / ultrasonic / magnetometer samples and vision results are
// rejected and counted; the IMU is held at its last good sample.
#include "lander/core/sample_screen.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lander/estimator/altitude_fusion.h"
#include "lander/estimator/navigation.h"

namespace lander {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

ImuSample hover_imu(double t) {
  ImuSample s;
  s.t_s = t;
  s.accel_B_mps2 = Eigen::Vector3d(0, 0, 9.81);
  s.gyro_B_radps = Eigen::Vector3d(0.01, 0, 0);
  return s;
}

TEST(SampleScreen, DefaultLimitsAreValidAndABadLimitIsNamed) {
  EXPECT_NO_THROW(SampleLimits{}.validate());
  SampleLimits l;
  l.max_pressure_pa = 1000;
  try {
    l.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "max_pressure_pa");
  }
}

TEST(SampleScreen, ImuIsHeldAtTheLastGoodSample) {
  SampleScreen screen{SampleLimits{}};
  ImuSample bad = hover_imu(0.0);
  bad.accel_B_mps2.x() = kNaN;
  EXPECT_FALSE(screen.imu(bad));  // nothing to hold yet
  EXPECT_TRUE(screen.imu(hover_imu(0.001)));
  bad.t_s = 0.002;
  const std::optional<ImuSample> held = screen.imu(bad);
  ASSERT_TRUE(held);
  EXPECT_EQ(held->t_s, 0.002);
  EXPECT_EQ(held->accel_B_mps2, hover_imu(0).accel_B_mps2);
  ImuSample absurd = hover_imu(0.003);
  absurd.gyro_B_radps.z() = 1e6;  // rad/s
  EXPECT_TRUE(screen.imu(absurd));
  ImuSample stamp = hover_imu(kNaN);
  EXPECT_FALSE(screen.imu(stamp));
  EXPECT_EQ(screen.rejected().imu, 4);
  EXPECT_EQ(screen.rejected().total(), 4);
}

TEST(SampleScreen, EachSensorRejectsNanAndAbsurdValues) {
  SampleScreen screen{SampleLimits{}};
  BaroSample b;
  EXPECT_TRUE(screen.accept(b));
  b.pressure_pa = kNaN;
  EXPECT_FALSE(screen.accept(b));
  b.pressure_pa = 5e6;
  EXPECT_FALSE(screen.accept(b));
  GpsSample g;
  EXPECT_TRUE(screen.accept(g));
  g.p_W_m.x() = kInf;
  EXPECT_FALSE(screen.accept(g));
  g.p_W_m = Eigen::Vector3d(1e9, 0, 0);
  EXPECT_FALSE(screen.accept(g));
  g.valid = false;  // a drop-out is a normal state of the receiver, not a fault
  EXPECT_TRUE(screen.accept(g));
  UltrasonicSample u;
  u.range_m = 1e6;  // out-of-range garbage (eq. 12) is the fusion's to reject
  EXPECT_TRUE(screen.accept(u));
  u.range_m = kNaN;
  EXPECT_FALSE(screen.accept(u));
  u.range_m = -1;
  EXPECT_FALSE(screen.accept(u));
  MagSample m;
  m.field_B_uT = Eigen::Vector3d(20, 0, -40);
  EXPECT_TRUE(screen.accept(m));
  m.field_B_uT.y() = kNaN;
  EXPECT_FALSE(screen.accept(m));
  m.field_B_uT = Eigen::Vector3d(1e5, 0, 0);
  EXPECT_FALSE(screen.accept(m));
  const RejectedSamples& r = screen.rejected();
  EXPECT_EQ(r.baro, 2);
  EXPECT_EQ(r.gps, 2);
  EXPECT_EQ(r.ultrasonic, 2);
  EXPECT_EQ(r.magnetometer, 2);
  EXPECT_EQ(r.total(), 8);
}

TEST(SampleScreen, VisionNeedsAFinitePoseARotationAndThePlatformInFront) {
  SampleScreen screen{SampleLimits{}};
  PlatformObservation o;
  o.detected = true;
  o.X_CP.translation() = Eigen::Vector3d(0.1, 0.2, 5.0);
  EXPECT_TRUE(screen.accept(o));
  PlatformObservation nan_pose = o;
  nan_pose.X_CP.translation().y() = kNaN;
  EXPECT_FALSE(screen.accept(nan_pose));
  PlatformObservation nan_cov = o;
  nan_cov.cov(2, 3) = kInf;
  EXPECT_FALSE(screen.accept(nan_cov));
  PlatformObservation skew = o;
  skew.X_CP.linear()(0, 1) = 0.5;
  EXPECT_FALSE(screen.accept(skew));
  PlatformObservation behind = o;
  behind.X_CP.translation().z() = -5.0;
  EXPECT_FALSE(screen.accept(behind));
  PlatformObservation none;  // no detection: no pose to check
  none.X_CP.translation().setConstant(kNaN);
  EXPECT_TRUE(screen.accept(none));
  EXPECT_EQ(screen.rejected().vision, 4);
}

// Before the screen existed, one non-finite accelerometer sample made the filter throw.
TEST(AltitudeFusionBadSamples, NonFiniteInputsAreSkippedNotThrown) {
  AltitudeFusion f{AltitudeFusionParams{}};
  f.reset(0.0, 10.0);
  EXPECT_NO_THROW(f.predict(0.01, kNaN));
  EXPECT_NO_THROW(f.predict(0.01, kInf));
  ImuSample imu = hover_imu(0.02);
  imu.accel_B_mps2.z() = kNaN;
  EXPECT_NO_THROW(f.predict(imu, Eigen::Quaterniond::Identity()));
  Eigen::Quaterniond q_bad(kNaN, 0, 0, 0);
  EXPECT_NO_THROW(f.predict(hover_imu(0.03), q_bad));
  EXPECT_EQ(f.rejected_inputs(), 4);
  f.predict(0.04, 0.0);
  BaroSample b;
  b.t_s = 0.04;
  b.pressure_pa = kInf;
  EXPECT_EQ(f.update_baro(b), AltitudeFusion::Outcome::kRejectedRange);
  GpsSample g;
  g.t_s = 0.04;
  g.p_W_m.z() = kNaN;
  EXPECT_EQ(f.update_gps(g), AltitudeFusion::Outcome::kRejectedRange);
  UltrasonicSample u;
  u.t_s = 0.04;
  u.range_m = kNaN;
  EXPECT_EQ(f.update_ultrasonic(u), AltitudeFusion::Outcome::kRejectedRange);
  EXPECT_EQ(f.update_vision(0.04, kNaN), AltitudeFusion::Outcome::kRejectedRange);
  EXPECT_TRUE(f.x().allFinite());
  EXPECT_TRUE(f.P().allFinite());
  EXPECT_NEAR(f.estimate().z_W_m, 10.0, 1e-3);
}

TEST(NavigationBadSamples, NonFiniteImuAndMagAreRefused) {
  Navigation nav{NavigationParams{}};
  EXPECT_TRUE(nav.add_imu(hover_imu(0.0)));
  ImuSample bad = hover_imu(0.001);
  bad.gyro_B_radps.x() = kNaN;
  EXPECT_FALSE(nav.add_imu(bad));
  MagSample m;
  m.t_s = 0.001;
  m.field_B_uT = Eigen::Vector3d(kNaN, 0, 0);
  EXPECT_FALSE(nav.add_mag(m));
  GpsSample g;
  g.t_s = 0.001;
  g.v_W_mps.x() = kNaN;
  EXPECT_FALSE(nav.add_gps(g));
  EXPECT_TRUE(nav.add_imu(hover_imu(0.002)));
  EXPECT_TRUE(nav.state().q_WB.coeffs().allFinite());
}

}  // namespace
}  // namespace lander
