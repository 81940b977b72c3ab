// Hex-X mixer: allocation reproduces the commanded wrench; saturation keeps roll/pitch.
#include "lander/controller/mixer.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

namespace lander::ctl {
namespace {

// Allocation is exact linear algebra on doubles: 1e-9 N (N m) is round-off with margin.
constexpr double kWrenchTol = 1e-9;

// Independent rotor model (the common vehicle facts), not the mixer's own matrix.
Wrench wrench_from_speeds(const std::array<double, 6>& w, const VehicleParams& v) {
  Wrench out;
  for (int k = 0; k < 6; ++k) {
    const double az = (30.0 + 60.0 * k) * M_PI / 180.0;
    const double T = v.k_thrust * w[k] * w[k];
    const Eigen::Vector3d r(v.arm_m * std::cos(az), v.arm_m * std::sin(az), 0.05);
    out.thrust_N += T;
    out.torque_B_Nm += r.cross(Eigen::Vector3d(0, 0, T));
    out.torque_B_Nm.z() += -((k % 2 == 0) ? 1.0 : -1.0) * v.k_torque * w[k] * w[k];
  }
  return out;
}

TEST(HexMixer, HoverIsSixEqualRotorsNearFiveHundredSixtySixRadPerSecond) {
  const VehicleParams v;
  const HexMixer m(v);
  Wrench d;
  d.thrust_N = v.mass_kg * v.gravity_mps2;
  const MixerOutput out = m.mix(d);
  EXPECT_FALSE(out.saturated);
  for (double w : out.w_radps) EXPECT_NEAR(w, std::sqrt(d.thrust_N / 6 / v.k_thrust), 1e-9);
  // Common facts quote w_hover ~ 566 rad/s; sqrt(m g / (6 kT)) = 564.8, so 2 rad/s covers
  // their rounding.
  constexpr double kFactsRounding_radps = 2.0;
  EXPECT_NEAR(out.w_radps[0], 566.0, kFactsRounding_radps);
}

TEST(HexMixer, AllocationReproducesCommandedWrench) {
  const VehicleParams v;
  const HexMixer m(v);
  const Wrench demands[] = {
      {40.0, Eigen::Vector3d(0.5, 0.0, 0.0)},
      {40.0, Eigen::Vector3d(0.0, -0.7, 0.0)},
      {35.0, Eigen::Vector3d(0.0, 0.0, 0.3)},
      {45.0, Eigen::Vector3d(0.8, -0.6, -0.2)},
  };
  for (const Wrench& d : demands) {
    const MixerOutput out = m.mix(d);
    EXPECT_FALSE(out.saturated);
    const Wrench got = wrench_from_speeds(out.w_radps, v);
    EXPECT_NEAR(got.thrust_N, d.thrust_N, kWrenchTol);
    EXPECT_NEAR((got.torque_B_Nm - d.torque_B_Nm).norm(), 0.0, kWrenchTol);
  }
}

TEST(HexMixer, RollTorqueOnRotorsOnTheLeftSide) {
  // Positive roll torque (about +x, right wing down... i.e. left side up) must speed up the
  // rotors with y > 0 (k = 0, 1, 2 at 30, 90, 150 deg).
  const HexMixer m(VehicleParams{});
  const MixerOutput out = m.mix({40.0, Eigen::Vector3d(1.0, 0, 0)});
  EXPECT_GT(out.w_radps[1], out.w_radps[4]);
  EXPECT_GT(out.w_radps[0], out.w_radps[5]);
}

TEST(HexMixer, SaturationScalesYawFirstAndKeepsRollPitch) {
  const VehicleParams v;
  const HexMixer m(v);
  // Near-full thrust plus roll plus a large yaw demand: rotors cannot give all of it.
  Wrench d;
  d.thrust_N = 60.0;
  d.torque_B_Nm = Eigen::Vector3d(1.5, 0.0, 1.0);
  const MixerOutput out = m.mix(d);
  EXPECT_TRUE(out.saturated);
  const Wrench got = wrench_from_speeds(out.w_radps, v);
  EXPECT_NEAR(got.torque_B_Nm.x(), 1.5, kWrenchTol) << "roll torque must be kept";
  EXPECT_NEAR(got.torque_B_Nm.y(), 0.0, kWrenchTol);
  EXPECT_LT(std::abs(got.torque_B_Nm.z()), 1.0) << "yaw is the first to give way";
  for (double w : out.w_radps) {
    EXPECT_LE(w, v.w_max_radps + 1e-9);
    EXPECT_GE(w, v.w_idle_radps - 1e-9);
  }
}

TEST(HexMixer, ThrustGivesWayToAttitudeAtFullThrust) {
  const VehicleParams v;
  const HexMixer m(v);
  Wrench d;
  d.thrust_N = 6 * m.thrust_max_N();  // everything
  d.torque_B_Nm = Eigen::Vector3d(0.0, 2.0, 0.0);
  const MixerOutput out = m.mix(d);
  EXPECT_TRUE(out.saturated);
  const Wrench got = wrench_from_speeds(out.w_radps, v);
  EXPECT_NEAR(got.torque_B_Nm.y(), 2.0, kWrenchTol) << "pitch torque must be kept";
  EXPECT_LT(got.thrust_N, d.thrust_N);
}

TEST(HexMixer, ImpossibleRollPitchIsScaledKeepingItsDirection) {
  const VehicleParams v;
  const HexMixer m(v);
  Wrench d;
  d.thrust_N = 40.0;
  d.torque_B_Nm = Eigen::Vector3d(30.0, -40.0, 0.0);  // far beyond the rotors
  const MixerOutput out = m.mix(d);
  EXPECT_TRUE(out.saturated);
  EXPECT_LT(out.roll_pitch_scale, 1.0);
  const Wrench got = wrench_from_speeds(out.w_radps, v);
  const Eigen::Vector2d want = d.torque_B_Nm.head<2>().normalized();
  const Eigen::Vector2d have = got.torque_B_Nm.head<2>().normalized();
  // Direction kept to round-off (1e-9 on unit vectors).
  EXPECT_NEAR((want - have).norm(), 0.0, 1e-9);
}

TEST(HexMixer, NegativeThrustDemandGivesIdle) {
  const VehicleParams v;
  const HexMixer m(v);
  const MixerOutput out = m.mix({-5.0, Eigen::Vector3d::Zero()});
  for (double w : out.w_radps) EXPECT_NEAR(w, v.w_idle_radps, 1e-9);
}

}  // namespace
}  // namespace lander::ctl
