// Navigation filter with exact, hand-made IMU and GPS samples. Tests with the sensor
// models live in tests/sim/fusion_navigation_test.cpp.
#include "lander/estimator/navigation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace lander {
namespace {

constexpr double kG = 9.81;

TEST(NavigationParams, DefaultIsValid) { EXPECT_NO_THROW(NavigationParams{}.validate()); }

TEST(NavigationParams, SaveLoadRoundTrip) {
  NavigationParams p;
  p.initial_yaw_rad = 0.5;
  p.compensate_accel = false;
  NavigationParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_NEAR(q.initial_yaw_rad, 0.5, 1e-15);
  EXPECT_FALSE(q.compensate_accel);
}

TEST(NavigationParams, BadValueNamesField) {
  NavigationParams p;
  try {
    read_params(YAML::Load("accel_gate_frac: 2"), "n.yaml", p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("accel_gate_frac"), std::string::npos) << e.what();
  }
}

ImuSample imu_at(double t, const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& gyro) {
  ImuSample s;
  s.t_s = t;
  s.accel_B_mps2 = R_WB.transpose() * Eigen::Vector3d(0, 0, kG);
  s.gyro_B_radps = gyro;
  return s;
}

GpsSample fix_at(double t, const Eigen::Vector3d& p_W, const Eigen::Vector3d& v_W) {
  GpsSample g;
  g.t_s = t;
  g.p_W_m = p_W;
  g.v_W_mps = v_W;
  return g;
}

TEST(Navigation, InitialisesRollPitchFromGravityAndYawFromParams) {
  NavigationParams p;
  p.initial_yaw_rad = M_PI / 2;
  Navigation nav(p);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  nav.add_imu(imu_at(0.0, R, Eigen::Vector3d::Zero()));
  EXPECT_FALSE(nav.state().valid);  // no GPS yet
  EXPECT_NEAR((nav.state().q_WB.toRotationMatrix() - R).norm(), 0.0, 1e-9);
}

TEST(Navigation, IntegratesGyroRate) {
  Navigation nav(NavigationParams{});
  const Eigen::Vector3d w(0.0, 0.0, 0.5);
  for (int k = 0; k <= 500; ++k) {  // 2 s at 250 Hz, level: the accel correction is zero
    const double t = k * 0.004;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    nav.add_imu(imu_at(t, R, w));
  }
  const Eigen::Matrix3d R_end = nav.state().q_WB.toRotationMatrix();
  EXPECT_NEAR(std::atan2(R_end(1, 0), R_end(0, 0)), 1.0, 1e-9);
  EXPECT_NEAR((nav.state().omega_B_radps - w).norm(), 0.0, 1e-12);
}

TEST(Navigation, EstimatesHorizontalGyroBias) {
  NavigationParams p;
  p.compensate_accel = false;
  Navigation nav(p);
  const Eigen::Vector3d bias(0.01, -0.01, 0.0);
  for (int k = 0; k <= 250 * 120; ++k) {  // 120 s level, at rest
    nav.add_imu(imu_at(k * 0.004, Eigen::Matrix3d::Identity(), bias));
  }
  // 1/ki = 20 s time constant: after 6 of them the residual is < 1 %.
  EXPECT_NEAR(nav.gyro_bias_B().x(), 0.01, 1e-4);
  EXPECT_NEAR(nav.gyro_bias_B().y(), -0.01, 1e-4);
  // The tilt stays near zero (steady error b / kp while converging).
  EXPECT_LT((nav.state().q_WB.toRotationMatrix().col(2) - Eigen::Vector3d::UnitZ()).norm(), 1e-3);
}

TEST(Navigation, GpsInitialisesPositionAndLatencyIsCompensated) {
  Navigation nav(NavigationParams{});
  nav.add_imu(imu_at(1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()));
  nav.add_imu(imu_at(1.1, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()));
  // Sampled at 1.0 s: 0.1 s old.
  GpsSample g = fix_at(1.0, Eigen::Vector3d(3.0, 4.0, 10.0), Eigen::Vector3d(1.0, 0.0, 0.0));
  EXPECT_TRUE(nav.add_gps(g));
  const NavState s = nav.state();
  EXPECT_TRUE(s.valid);
  EXPECT_NEAR((s.p_W_m - Eigen::Vector3d(3.1, 4.0, 10.0)).norm(), 0.0, 1e-12);
  // Invalid and stale fixes are refused.
  g.valid = false;
  EXPECT_FALSE(nav.add_gps(g));
  g.valid = true;
  g.t_s = 0.0;
  EXPECT_FALSE(nav.add_gps(g));
  // The fused altitude replaces the GPS height.
  AltitudeEstimate alt;
  alt.valid = true;
  alt.z_W_m = 9.5;
  alt.vz_W_mps = -0.2;
  const NavState m = with_altitude(s, alt);
  EXPECT_EQ(m.p_W_m.z(), 9.5);
  EXPECT_EQ(m.v_W_mps.z(), -0.2);
  EXPECT_EQ(m.p_W_m.x(), s.p_W_m.x());
}

TEST(Navigation, TracksConstantVelocityFromGps) {
  Navigation nav(NavigationParams{});
  double t = 0.0;
  for (int k = 0; k <= 250 * 30; ++k) {
    t = k * 0.004;
    nav.add_imu(imu_at(t, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()));
    if (k % 50 == 0) {  // 5 Hz, exact
      nav.add_gps(fix_at(t, Eigen::Vector3d(2.0 * t, 0.0, 10.0), Eigen::Vector3d(2.0, 0.0, 0.0)));
    }
  }
  const NavState s = nav.state();
  // Exact data: the filter follows to well under a centimetre (only the 4 ms IMU step and
  // the accel-bias state's transient remain).
  EXPECT_NEAR(s.p_W_m.x(), 2.0 * t, 0.01);
  EXPECT_NEAR(s.v_W_mps.x(), 2.0, 0.01);
}

// A multirotor's accelerometer reads its thrust along body z whatever its tilt: roll to
// 20 deg at 0.5 s (at 40 deg/s) and hold it, the accelerometer reading (0, 0, g / cos) in B.
ImuSample banked_at(double t) {
  constexpr double kRate_radps = 40.0 * M_PI / 180.0, kT0 = 0.5, kT1 = 1.0;
  const double roll = kRate_radps * std::clamp(t - kT0, 0.0, kT1 - kT0);
  ImuSample s;
  s.t_s = t;
  s.accel_B_mps2 = Eigen::Vector3d(0, 0, kG / std::cos(roll));
  s.gyro_B_radps = Eigen::Vector3d(t >= kT0 && t < kT1 ? kRate_radps : 0.0, 0, 0);
  return s;
}

double roll_deg(const NavState& s) {
  const Eigen::Vector3d up_B = s.q_WB.conjugate() * Eigen::Vector3d::UnitZ();
  return std::atan2(up_B.y(), up_B.z()) * 180.0 / M_PI;
}

TEST(Navigation, StartInGpsDropOutIsFlownOnTheGyro) {
  // One fix at the start, then none (a drop-out from the start): no pair of fixes gives the
  // GPS-derived acceleration, and plain Mahony would take the thrust axis for "up".
  auto run = [](bool compensate) {
    NavigationParams p;
    p.compensate_accel = compensate;
    Navigation nav(p);
    for (int k = 0; k <= 250 * 3; ++k) {
      const double t = k * 0.004;
      nav.add_imu(banked_at(t));
      if (k == 0) {
        nav.add_gps(fix_at(t, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d::Zero()));
      }
    }
    return roll_deg(nav.state());
  };
  // Exact gyro: the 20 deg roll is kept to the integration's rounding.
  EXPECT_NEAR(run(true), 20.0, 0.01);
  // Plain Mahony (kp 1/s for 2 s of the bank) reads it as a few degrees: the test sees it.
  EXPECT_LT(run(false), 10.0);
}

TEST(Navigation, FirstFixAfterDropOutSetsTheVelocity) {
  // Hover with fixes at 5 Hz, then 3 s without fixes in which the accelerometer reads a
  // horizontal 1 m/s^2 the fixes do not have (the coasted velocity ends 3 m/s off, far
  // beyond the residual gate), then fixes at rest again.
  Navigation nav(NavigationParams{});
  double v_after_first_fix = NAN;
  for (int k = 0; k <= 250 * 12; ++k) {
    const double t = k * 0.004;
    ImuSample s = imu_at(t, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    const bool gap = t >= 5.0 && t < 8.0;
    if (gap) s.accel_B_mps2.x() = 1.0;
    nav.add_imu(s);
    if (k % 50 == 0 && !gap) {
      EXPECT_TRUE(nav.add_gps(fix_at(t, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d::Zero())));
      if (t >= 8.0 && std::isnan(v_after_first_fix)) v_after_first_fix = nav.state().v_W_mps.x();
    }
  }
  EXPECT_EQ(nav.velocity_resets(), 1);
  // The fix's velocity (exact here), not 3 m/s less a tenth of the innovation.
  EXPECT_NEAR(v_after_first_fix, 0.0, 1e-9);
  EXPECT_NEAR(nav.state().v_W_mps.x(), 0.0, 0.05);
}

// NavState::v_corr_W_mps sums the steps the fixes make in the velocity and nothing else: the
// IMU's integration leaves it alone, each fix (also the velocity taken after a drop-out) adds
// its horizontal change of v_W_mps, and its z stays 0. The platform tracker moves its
// dead-reckoned history by its changes, so a missed or wrong sum would reach the landing.
TEST(Navigation, VelocityCorrectionsAreSummedHorizontallyInVCorr) {
  Navigation nav(NavigationParams{});
  int fixes_seen = 0;
  double largest_step = 0.0, smallest_step = 1e9;
  for (int k = 0; k <= 250 * 12; ++k) {
    const double t = k * 0.004;
    ImuSample s = imu_at(t, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    // A drop-out at 5-8 s in which the accelerometer reads a horizontal acceleration the
    // fixes do not have (the coasted velocity ends ~3.4 m/s off, as in
    // FirstFixAfterDropOutSetsTheVelocity).
    const bool gap = t >= 5.0 && t < 8.0;
    if (gap) {
      s.accel_B_mps2.x() += 1.0;
      s.accel_B_mps2.y() -= 0.5;
    }
    const NavState before_imu = nav.state();
    nav.add_imu(s);
    if (before_imu.valid) {
      // Exact: the IMU step does not touch the sum.
      EXPECT_EQ(nav.state().v_corr_W_mps, before_imu.v_corr_W_mps) << "t " << t;
    }
    if (k % 50 != 0 || gap) continue;
    const NavState before = nav.state();
    // The fixes' velocities alternate by +-5 cm/s (receiver noise), so every update steps.
    const double noise = (k / 50) % 2 == 0 ? 0.05 : -0.05;
    ASSERT_TRUE(
        nav.add_gps(fix_at(t, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d(noise, -noise, 0.0))));
    const NavState after = nav.state();
    if (!before.valid) {  // the first fix initialises the velocity: not a correction
      EXPECT_EQ(after.v_corr_W_mps, Eigen::Vector3d::Zero());
      continue;
    }
    ++fixes_seen;
    const Eigen::Vector3d step = after.v_W_mps - before.v_W_mps;
    const Eigen::Vector3d corr = after.v_corr_W_mps - before.v_corr_W_mps;
    // The same sum of the same doubles up to their rounding (1e-12 m/s).
    constexpr double kRounding_mps = 1e-12;
    EXPECT_NEAR(corr.x(), step.x(), kRounding_mps) << "t " << t;
    EXPECT_NEAR(corr.y(), step.y(), kRounding_mps) << "t " << t;
    EXPECT_EQ(after.v_corr_W_mps.z(), 0.0);
    largest_step = std::max(largest_step, step.head<2>().norm());
    if (t < 5.0) smallest_step = std::min(smallest_step, step.head<2>().norm());
  }
  EXPECT_GT(fixes_seen, 40);
  EXPECT_EQ(nav.velocity_resets(), 1);
  // Every ordinary fix moved the velocity (the sum is not trivially zero) ...
  EXPECT_GT(smallest_step, 1e-4);
  // ... and the fix after the drop-out took the velocity from the fix: ~3.4 m/s undone at once.
  EXPECT_GT(largest_step, 2.0);
}

}  // namespace
}  // namespace lander
