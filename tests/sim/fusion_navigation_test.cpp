// Navigation filter (Mahony attitude + per-axis GPS/accelerometer Kalman filter) driven by
// the IMU and GPS models along analytic trajectories.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <functional>
#include <iostream>

#include "lander/estimator/navigation.h"
#include "lander/sim/sensors/sensors.h"

namespace lander::sim {
namespace {

// Runs use seed 1 unless LANDER_TEST_SEED is set (to check that a pass is not one lucky draw:
// for s in $(seq 1 40); do LANDER_TEST_SEED=$s ./fusion_..._test; done).
std::uint64_t seed_from_env() {
  const char* s = std::getenv("LANDER_TEST_SEED");
  return s ? std::stoull(s) : 1;
}

constexpr double kG = 9.81;
constexpr double kDeg = M_PI / 180.0;

// Attitude of a multirotor that produces acceleration a_W with yaw psi: body z along
// a_W + g e_z (thrust direction), x as close to the yaw direction as possible.
Eigen::Matrix3d attitude_for(const Eigen::Vector3d& a_W, double yaw) {
  const Eigen::Vector3d z = (a_W + Eigen::Vector3d(0, 0, kG)).normalized();
  const Eigen::Vector3d xc(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d y = z.cross(xc).normalized();
  Eigen::Matrix3d R;
  R.col(0) = y.cross(z);
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

struct Traj {
  std::function<Eigen::Vector3d(double)> p;  // position in W
  double yaw{0.0};
  Eigen::Matrix3d R_fixed{Eigen::Matrix3d::Identity()};
  bool fixed_attitude{false};
};

VehicleTruth truth_at(const Traj& tr, double t) {
  constexpr double d = 1e-3;
  VehicleTruth v;
  v.t_s = t;
  const Eigen::Vector3d p = tr.p(t);
  v.X_WB.translation() = p;
  v.v_W_mps = (tr.p(t + d) - tr.p(t - d)) / (2 * d);
  v.a_W_mps2 = (tr.p(t + d) - 2 * p + tr.p(t - d)) / (d * d);
  auto R_at = [&](double s) {
    if (tr.fixed_attitude) return tr.R_fixed;
    const Eigen::Vector3d a = (tr.p(s + d) - 2 * tr.p(s) + tr.p(s - d)) / (d * d);
    return attitude_for(a, tr.yaw);
  };
  const Eigen::Matrix3d R = R_at(t);
  v.X_WB.linear() = R;
  // omega_B from R^T dR/dt (skew-symmetric part).
  const Eigen::Matrix3d W = R.transpose() * (R_at(t + d) - R_at(t - d)) / (2 * d);
  v.omega_B_radps = Eigen::Vector3d(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1)) / 2;
  return v;
}

struct NavResult {
  double tilt_err_rms_deg{0}, tilt_err_max_deg{0};
  double pos_h_rmse_m{0}, vel_rmse_mps{0};
  double max_pos_err_in_window_m{0};
  double max_pos_err_growth_in_window_m{0};  // |e(t) - e(window start)|, horizontal
  double tilt_err_max_in_window_deg{0};      // over [window_t0, window_t1 + 1 s)
  double vel_err_max_in_window_mps{0};       // horizontal, same period
  Eigen::Vector3d gyro_bias_err{Eigen::Vector3d::Zero()};
  Eigen::Vector3d accel_bias_B{Eigen::Vector3d::Zero()};  // the IMU's (truth) at the end
  Eigen::Vector3d gyro_bias_B{Eigen::Vector3d::Zero()};   // the IMU's (truth) at the end
  double gps_h_rmse_m{0};  // raw GPS fixes' horizontal error over the same period
};

// Roll/pitch error: angle between the true and estimated "up" seen in B, R^T e_z. This is
// independent of yaw, which drifts (no magnetometer; comparing body axes in W would mix the
// yaw drift into the tilt).
double tilt_error_deg(const Eigen::Matrix3d& R_true, const Eigen::Quaterniond& q_est) {
  const Eigen::Vector3d up_est = q_est.toRotationMatrix().transpose().col(2);
  const Eigen::Vector3d up_true = R_true.transpose().col(2);
  return std::acos(std::clamp(up_est.dot(up_true), -1.0, 1.0)) / kDeg;
}

NavResult run(const Traj& tr, double T, NavigationParams np, SensorSuiteParams sp,
              double window_t0 = -1, double window_t1 = -1, double settle_s = 20.0) {
  const std::uint64_t sd = seed_from_env();
  ImuModel imu(sp.imu, 10 + sd);
  GpsModel gps(sp.gps, 11 + sd * 7);
  // A scripted drop-out [window_t0, window_t1): those fixes are not delivered.
  DelayQueue<GpsSample> qg;
  Navigation nav(np);
  NavResult r;
  double ss_tilt = 0, ss_p = 0, ss_v = 0;
  Eigen::Vector2d e_start = Eigen::Vector2d::Zero();
  double ss_gps = 0;
  int n_gps = 0;
  int n = 0;
  for (int k = 0; k <= static_cast<int>(T * 1000); ++k) {
    const double t = k * 1e-3;
    const VehicleTruth v = truth_at(tr, t);
    if (imu.due(t)) nav.add_imu(imu.sample(v));
    if (gps.due(t)) qg.push(gps.sample(v), t + sp.gps.latency_s);
    for (const auto& g : qg.pop_ready(t)) {
      if (g.t_s >= window_t0 && g.t_s < window_t1) continue;  // scripted drop-out
      if (g.t_s >= settle_s) {
        ss_gps += (g.p_W_m - truth_at(tr, g.t_s).X_WB.translation()).head<2>().squaredNorm() / 2;
        ++n_gps;
      }
      nav.add_gps(g);
    }
    if (k % 20 == 0 && t >= settle_s) {
      const NavState s = nav.state();
      EXPECT_TRUE(s.valid);
      const double e = tilt_error_deg(v.X_WB.linear(), s.q_WB);
      ss_tilt += e * e;
      r.tilt_err_max_deg = std::max(r.tilt_err_max_deg, e);
      ss_p += (s.p_W_m - v.X_WB.translation()).head<2>().squaredNorm() / 2;
      ss_v += (s.v_W_mps - v.v_W_mps).squaredNorm() / 3;
      ++n;
      const Eigen::Vector2d ep = (s.p_W_m - v.X_WB.translation()).head<2>();
      if (t < window_t0) e_start = ep;
      if (t >= window_t0 && t < window_t1 + 1.0) {
        r.max_pos_err_in_window_m = std::max(r.max_pos_err_in_window_m, ep.norm());
        r.max_pos_err_growth_in_window_m =
            std::max(r.max_pos_err_growth_in_window_m, (ep - e_start).norm());
        r.tilt_err_max_in_window_deg = std::max(r.tilt_err_max_in_window_deg, e);
        r.vel_err_max_in_window_mps = std::max(
            r.vel_err_max_in_window_mps, (s.v_W_mps - v.v_W_mps).head<2>().norm());
      }
    }
  }
  r.tilt_err_rms_deg = std::sqrt(ss_tilt / n);
  r.pos_h_rmse_m = std::sqrt(ss_p / n);
  r.vel_rmse_mps = std::sqrt(ss_v / n);
  r.gyro_bias_err = nav.gyro_bias_B() - imu.gyro_bias_B();
  r.accel_bias_B = imu.accel_bias_B();
  r.gyro_bias_B = imu.gyro_bias_B();
  r.gps_h_rmse_m = n_gps ? std::sqrt(ss_gps / n_gps) : 0.0;
  return r;
}

Traj static_tilted() {
  Traj tr;
  tr.p = [](double) { return Eigen::Vector3d(0, 0, 10); };
  tr.fixed_attitude = true;
  tr.R_fixed = (Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(-5 * kDeg, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return tr;
}

TEST(FusionNavigation, StaticTiltConvergesAndEstimatesGyroBias) {
  const Traj tr = static_tilted();
  NavigationParams np;
  np.initial_yaw_rad = 30 * kDeg;
  np.compensate_accel = false;  // plain Mahony: gravity is the only reference
  SensorSuiteParams sp;  // default IMU: 5 mrad/s turn-on gyro bias, 0.05 m/s^2 accel bias
  const NavResult r = run(tr, 120.0, np, sp, -1, -1, 60.0);
  // The accelerometer bias of this run tilts the gravity reference by b_perp / g, with b_perp
  // its part across the true "up" in B: the attitude cannot be better than that. On top:
  // white accel noise averaged over 1/kp = 1 s (0.03 / sqrt(250) rad, < 0.01 deg), the
  // residual gyro bias over kp (< 2e-3 rad/s -> 0.1 deg) and the accel bias random walk.
  const Eigen::Vector3d up_B = tr.R_fixed.transpose().col(2);
  const Eigen::Vector3d b_perp = r.accel_bias_B - r.accel_bias_B.dot(up_B) * up_B;
  const double bias_tilt_deg = std::atan(b_perp.norm() / kG) / kDeg;
  constexpr double kTiltBeyondBias_deg = 0.2;
  EXPECT_LT(r.tilt_err_max_deg, bias_tilt_deg + kTiltBeyondBias_deg);
  // Gyro bias components about the horizontal world axes are observable through gravity
  // (about the vertical they are not). Mahony's integral term follows them with a ~1/ki =
  // 20 s memory, over which the bias random walk moves 1e-4 * sqrt(20) = 4.5e-4 rad/s per
  // axis (1 sigma): 3 sigma over two axes is 4.5e-4 * 3 * sqrt(2) = 1.9e-3 rad/s, well under
  // the 5e-3 rad/s turn-on bias it started from.
  constexpr double kGyroBiasTolerance_radps = 1.9e-3;
  const Eigen::Vector3d err_W = tr.R_fixed * r.gyro_bias_err;
  EXPECT_LT(err_W.head<2>().norm(), kGyroBiasTolerance_radps);
}

TEST(FusionNavigation, StaticWithAccelCompensation) {
  // Default params: the GPS-derived acceleration is subtracted. At rest it is only noise:
  // differenced 0.1 m/s velocity noise at 5 Hz is 0.7 m/s^2 per fix, low-passed (0.5 s) to
  // ~0.3 m/s^2 and averaged by kp over ~1 s to ~0.15 m/s^2, i.e. ~0.9 deg; 0.4 deg from the
  // accel bias on top. 3 sigma of the noise plus the bias:
  const Traj tr = static_tilted();
  NavigationParams np;
  np.initial_yaw_rad = 30 * kDeg;
  const NavResult r = run(tr, 120.0, np, SensorSuiteParams{}, -1, -1, 60.0);
  constexpr double kTiltTolerance_deg = 0.4 + 3 * 0.9;
  EXPECT_LT(r.tilt_err_max_deg, kTiltTolerance_deg);
  constexpr double kTiltRmsTolerance_deg = 0.4 + 0.9;
  EXPECT_LT(r.tilt_err_rms_deg, kTiltRmsTolerance_deg);
}

Traj circle() {
  Traj tr;
  tr.p = [](double t) {
    constexpr double kRadius_m = 5.0, kSpeed_mps = 2.0;  // 0.8 m/s^2 centripetal, 4.7 deg
    const double w = kSpeed_mps / kRadius_m;
    return Eigen::Vector3d(kRadius_m * std::cos(w * t), kRadius_m * std::sin(w * t), 10.0);
  };
  return tr;
}

TEST(FusionNavigation, CircleAccelCompensationIsExactWithoutSensorErrors) {
  // Noise- and bias-free sensors: what is left is the algorithm's own error (low-pass
  // alignment, latency compensation), which must be far below the 4.7 deg bank angle.
  SensorSuiteParams sp;
  sp.gps.horizontal_std_m = sp.gps.vertical_std_m = 0.0;
  sp.gps.velocity_std_mps = 0.0;
  sp.imu.gyro_bias_init_std_radps = sp.imu.accel_bias_init_std_mps2 = 0.0;
  sp.imu.gyro_bias_rw_radps_per_sqrts = sp.imu.accel_bias_rw_mps2_per_sqrts = 0.0;
  const NavResult r = run(circle(), 120.0, NavigationParams{}, sp);
  constexpr double kAlgorithmTilt_deg = 1.0;
  EXPECT_LT(r.tilt_err_max_deg, kAlgorithmTilt_deg);
  EXPECT_LT(r.pos_h_rmse_m, 0.05);   // 5 cm: only the filter's own lag remains
  EXPECT_LT(r.vel_rmse_mps, 0.05);
}

TEST(FusionNavigation, CircleWithSensorErrors) {
  SensorSuiteParams sp;
  NavigationParams np;
  const NavResult r = run(circle(), 120.0, np, sp);
  np.compensate_accel = false;
  const NavResult u = run(circle(), 120.0, np, sp);
  std::cout << "circle: tilt rms " << r.tilt_err_rms_deg << " deg (plain Mahony "
            << u.tilt_err_rms_deg << "), max " << r.tilt_err_max_deg << " deg, pos rmse "
            << r.pos_h_rmse_m << " m (GPS " << r.gps_h_rmse_m << " m), vel rmse "
            << r.vel_rmse_mps << " m/s, z gyro bias " << r.gyro_bias_B.z() << " rad/s\n";
  // Plain Mahony takes the 4.7 deg bank for "level"; compensation removes part of that.
  // What remains comes from the yaw drift (no magnetometer: the z gyro bias turns the
  // subtracted acceleration by the yaw error psi, leaving 2 sin(psi / 2) of it, less than
  // all of it while |psi| < 60 deg, i.e. over these 120 s for a z bias under 8.7 mrad/s,
  // 1.7 sigma of the default IMU) and the GPS-derived acceleration noise.
  EXPECT_GT(u.tilt_err_rms_deg, 3.5);
  constexpr double kYawDriftLimit_radps = 60.0 * kDeg / 120.0;  // 60 deg in 120 s
  if (std::abs(r.gyro_bias_B.z()) < kYawDriftLimit_radps) {
    EXPECT_LT(r.tilt_err_rms_deg, u.tilt_err_rms_deg);
  }
  // Position cannot beat the GPS's correlated error (0.7 m std, 10 s correlation time),
  // but must not add to it: compared with the raw fixes of the same run (5 % for the
  // filter's lag); velocity is smoothed below the GPS's 0.1 m/s white noise.
  constexpr double kNoWorseThanGps = 1.05;
  EXPECT_LT(r.pos_h_rmse_m, kNoWorseThanGps * r.gps_h_rmse_m);
  EXPECT_LT(r.vel_rmse_mps, sp.gps.velocity_std_mps);
}

TEST(FusionNavigation, CoastsThroughGpsDropout) {
  Traj tr;
  tr.p = [](double t) { return Eigen::Vector3d(0.5 * t, 0.0, 10.0); };  // 0.5 m/s cruise
  NavigationParams np;
  SensorSuiteParams sp;
  const NavResult r = run(tr, 60.0, np, sp, 30.0, 33.0);
  // 3 s of accelerometer coasting (plus the 1 s until fixes are back in the filter). The
  // error at the start is the GPS's own (correlated, ~0.7 m); what the drop-out adds is the
  // drift: residual horizontal acceleration error (accel bias estimate ~0.05 m/s^2 plus
  // ~1 deg of tilt, 0.17 m/s^2) over 4 s, 0.5 * 0.22 * 16 = 1.8 m, plus a 0.1 m/s velocity
  // error over 4 s, 0.4 m.
  constexpr double kCoastGrowth_m = 2.2;
  EXPECT_LT(r.max_pos_err_growth_in_window_m, kCoastGrowth_m);
  std::cout << "drop-out: error growth " << r.max_pos_err_growth_in_window_m << " m\n";
}

TEST(FusionNavigation, ManoeuvreInGpsDropoutKeepsTheTilt) {
  // Hover, then within a 3 s drop-out (fixes sampled in [30, 33) s are lost) a dash of
  // 4.5 m: velocity 0 -> 3 -> 0 m/s as (1 - cos) over 3 s, peak acceleration 3.1 m/s^2
  // (a 17.8 deg tilt), the acceleration one way for 1.5 s, then the other. Plain Mahony would
  // read the thrust axis as "up" (the header); the gyro alone keeps the tilt.
  Traj tr;
  constexpr double kT0 = 30.0, kDash_s = 3.0, kPeakV = 3.0;
  tr.p = [=](double t) {
    const double tau = std::clamp(t - kT0, 0.0, kDash_s);
    const double w = 2.0 * M_PI / kDash_s;
    return Eigen::Vector3d(0.5 * kPeakV * (tau - std::sin(w * tau) / w), 0.0, 10.0);
  };
  SensorSuiteParams sp;
  NavigationParams np;
  const NavResult r = run(tr, 40.0, np, sp, kT0, kT0 + kDash_s);
  np.gps_loss_gyro_only_s = 0.0;  // plain Mahony once the last fix's hold ends (as before)
  const NavResult u = run(tr, 40.0, np, sp, kT0, kT0 + kDash_s);
  std::cout << "dash in a drop-out: tilt error max " << r.tilt_err_max_in_window_deg
            << " deg (plain Mahony " << u.tilt_err_max_in_window_deg << "), velocity error max "
            << r.vel_err_max_in_window_mps << " m/s (" << u.vel_err_max_in_window_mps << ")\n";
  // What the gyro alone keeps is the tilt error the filter had when the fixes stopped: the
  // compensated filter's own noise (differenced GPS velocity: 0.3-2.5 deg at hover over
  // seeds 1-30), plus the residual gyro bias over 3-4 s (tenths of a degree). Holding the
  // 17.8 deg tilt as "level" costs 9-10 deg (same seeds).
  constexpr double kGyroOnlyTilt_deg = 3.0;
  EXPECT_LT(r.tilt_err_max_in_window_deg, kGyroOnlyTilt_deg);
  // Plain Mahony: kp 1/s pulls towards level through the 1.5 s of acceleration each way.
  // This shows the test sees the difference.
  constexpr double kPlainMahonyAtLeast_deg = 6.0;
  EXPECT_GT(u.tilt_err_max_in_window_deg, kPlainMahonyAtLeast_deg);
  // 3 deg of tilt is 0.5 m/s^2 of horizontal acceleration error, but only the part that
  // stays: ~1 deg (0.17 m/s^2) over the 4 s until the fixes are back, 0.7 m/s, plus the
  // 0.1 m/s GPS velocity noise at the gap's start (seeds 1-30: 0.17-0.86 m/s; plain
  // Mahony 1.5-2.1 m/s).
  constexpr double kGyroOnlyVelocity_mps = 1.0;
  EXPECT_LT(r.vel_err_max_in_window_mps, kGyroOnlyVelocity_mps);
}

}  // namespace
}  // namespace lander::sim
