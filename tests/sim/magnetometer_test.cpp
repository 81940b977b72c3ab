// Magnetometer model and the navigation filter's yaw correction from it.
#include <gtest/gtest.h>

#include <cmath>

#include "lander/estimator/navigation.h"
#include "lander/sim/sensors/sensors.h"

namespace lander::sim {
namespace {

TEST(Magnetometer, MeanIsTheRotatedFieldPlusItsBias) {
  MagnetometerParams p;
  MagnetometerModel m(p, 5);
  VehicleTruth truth;
  truth.X_WB.linear() = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX())).toRotationMatrix();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    truth.t_s = i / p.rate_hz;
    sum += m.sample(truth).field_B_uT;
  }
  const Eigen::Vector3d expect = truth.X_WB.linear().transpose() * p.field_W_uT + m.bias_B_uT();
  // Mean of n samples with white noise sigma: 5 sigma / sqrt(n) bounds the error.
  EXPECT_LT((sum / n - expect).norm(), 5 * p.noise_std_uT / std::sqrt(n) * std::sqrt(3.0));
}

TEST(Magnetometer, NavigationYawFollowsTheCompassDespiteAGyroBias) {
  // A vehicle at rest, yawed 1.2 rad, with a z-gyro bias of 0.01 rad/s the filter cannot see
  // from gravity: without the magnetometer yaw would drift by 1.2 rad in 120 s.
  NavigationParams np;
  Navigation nav(np);
  MagnetometerParams mp;
  MagnetometerModel mag(mp, 9);
  VehicleTruth truth;
  truth.X_WB.linear() = Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double worst_late = 0;
  for (int i = 0; i <= 120 * 250; ++i) {
    const double t = i / 250.0;
    ImuSample imu;
    imu.t_s = t;
    imu.gyro_B_radps = Eigen::Vector3d(0, 0, 0.01);
    imu.accel_B_mps2 = truth.X_WB.linear().transpose() * Eigen::Vector3d(0, 0, 9.81);
    nav.add_imu(imu);
    truth.t_s = t;
    if (mag.due(t)) nav.add_mag(mag.sample(truth));
    const Eigen::Matrix3d R = nav.state().q_WB.toRotationMatrix();
    const double yaw = std::atan2(R(1, 0), R(0, 0));
    if (t > 10) worst_late = std::max(worst_late, std::abs(std::remainder(yaw - 1.2, 2 * M_PI)));
  }
  // Steady yaw error of a first-order correction against a rate bias: b / k = 0.02 rad, plus
  // the heading error of the 0.5 uT residual bias on a 22 uT horizontal field (~0.03 rad).
  EXPECT_LT(worst_late, 0.06);
}

}  // namespace
}  // namespace lander::sim
