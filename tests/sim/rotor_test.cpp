// Rotor and motor model: thrust law, hover trim, lag, saturation, free fall.
#include "lander/sim/plant/rotor.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lander::sim {
namespace {

constexpr double kMass_kg = 4.0;
constexpr double kG = 9.81;
// Issue 4: the trimmed hover speed must carry the weight within 1 %.
constexpr double kHoverTolerance = 0.01;
// Exact discretisation of the lag: only rounding error remains.
constexpr double kLagTolerance_radps = 1e-9;

TEST(RotorParams, DefaultIsValid) { EXPECT_NO_THROW(RotorParams{}.validate()); }

TEST(RotorParams, SaveLoadRoundTrip) {
  RotorParams p;
  p.kT = 2.2e-5;
  p.tau_s = 0.07;
  RotorParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_EQ(q.kT, p.kT);
  EXPECT_EQ(q.tau_s, p.tau_s);
}

TEST(RotorParams, BadValueNamesField) {
  RotorParams p;
  try {
    read_params(YAML::Load("tau_s: -1"), "r.yaml", p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("tau_s"), std::string::npos) << e.what();
  }
}

TEST(Rotor, ThrustAndTorqueAreQuadraticInSpeed) {
  const RotorParams p;
  EXPECT_DOUBLE_EQ(rotor_thrust_N(p, 500.0), 2.05e-5 * 500.0 * 500.0);
  EXPECT_DOUBLE_EQ(rotor_torque_Nm(p, 500.0), 3.3e-7 * 500.0 * 500.0);
  // Full thrust per rotor ~13.1 N (vehicle facts).
  EXPECT_NEAR(rotor_thrust_N(p, p.w_max_radps), 13.12, 0.01);
}

TEST(Rotor, LayoutIsHexXWithAlternatingSpins) {
  const RotorParams p;
  for (int k = 0; k < kNumRotors; ++k) {
    const Eigen::Vector3d r = rotor_position_B(p, k);
    EXPECT_NEAR(std::hypot(r.x(), r.y()), 0.425, 1e-12);
    EXPECT_NEAR(std::atan2(r.y(), r.x()),
                std::remainder((30.0 + 60.0 * k) * M_PI / 180.0, 2 * M_PI), 1e-12);
    EXPECT_NEAR(r.z(), 0.05, 1e-12);
    EXPECT_EQ(rotor_spin(k), k % 2 == 0 ? 1 : -1);
  }
  // Motor to motor across the hub: 0.85 m.
  EXPECT_NEAR((rotor_position_B(p, 0) - rotor_position_B(p, 3)).norm(), 0.85, 1e-12);
  EXPECT_THROW(rotor_position_B(p, 6), std::out_of_range);
}

TEST(Rotor, HoverSpeedCarriesWeightWithinOnePercent) {
  const RotorParams p;
  const double w = hover_speed_radps(p, kMass_kg, kG);
  // Vehicle facts quote w_hover ~ 566 rad/s (rounded); sqrt(m g / 6 kT) = 564.8 rad/s.
  constexpr double kQuotedHoverTolerance_radps = 2.0;
  EXPECT_NEAR(w, 566.0, kQuotedHoverTolerance_radps);
  RotorArray ws;
  ws.fill(w);
  const BodyWrench b = rotor_wrench(p, ws);
  EXPECT_NEAR(b.force_B_N.z() / (kMass_kg * kG), 1.0, kHoverTolerance);
  EXPECT_NEAR(b.force_B_N.head<2>().norm(), 0.0, 1e-12);
  // Equal speeds: thrust moments and reaction torques cancel.
  EXPECT_NEAR(b.torque_B_Nm.norm(), 0.0, 1e-9);
  // Hover near 50 % of full thrust.
  const double frac = (w * w) / (p.w_max_radps * p.w_max_radps);
  EXPECT_GT(frac, 0.4);
  EXPECT_LT(frac, 0.6);
}

TEST(Rotor, DifferentialSpeedsGiveExpectedTorqueSigns) {
  const RotorParams p;
  RotorArray ws;
  ws.fill(560.0);
  // Left rotors (k = 0, 1, 2 have y > 0) faster: positive roll torque about +x_B.
  RotorArray left = ws;
  for (int k : {0, 1, 2}) left[k] += 20.0;
  EXPECT_GT(rotor_wrench(p, left).torque_B_Nm.x(), 0.0);
  // Front rotors (k = 0, 5 have x > 0) faster: nose up = negative pitch about +y_B.
  RotorArray front = ws;
  for (int k : {0, 5}) front[k] += 20.0;
  EXPECT_LT(rotor_wrench(p, front).torque_B_Nm.y(), 0.0);
  // CCW rotors (even k) faster: reaction torque -s kQ w^2 turns the body clockwise (-z).
  RotorArray ccw = ws;
  for (int k : {0, 2, 4}) ccw[k] += 20.0;
  const BodyWrench b = rotor_wrench(p, ccw);
  const double expected = -3 * p.kQ * (580.0 * 580.0 - 560.0 * 560.0);
  EXPECT_NEAR(b.torque_B_Nm.z(), expected, 1e-12);
  EXPECT_NEAR(b.torque_B_Nm.x(), 0.0, 1e-9);
  EXPECT_NEAR(b.torque_B_Nm.y(), 0.0, 1e-9);
}

TEST(Rotor, ThrustFactorScalesOnlyThrust) {
  const RotorParams p;
  RotorArray ws;
  ws.fill(500.0);
  RotorArray f;
  f.fill(1.2);
  EXPECT_NEAR(rotor_wrench(p, ws, f).force_B_N.z(), 1.2 * rotor_wrench(p, ws).force_B_N.z(),
              1e-9);
}

TEST(MotorBank, FirstOrderLagReaches63PercentAfterTau) {
  const RotorParams p;
  MotorBank m(p);
  RotorArray cmd;
  cmd.fill(500.0);
  const double dt = 1e-3;
  const int n = static_cast<int>(std::lround(p.tau_s / dt));
  for (int i = 0; i < n; ++i) m.step(cmd, dt);
  for (double w : m.speeds_radps()) {
    EXPECT_NEAR(w, 500.0 * (1.0 - std::exp(-1.0)), kLagTolerance_radps * 500.0);
  }
  // Independent of the step size (exact discretisation).
  MotorBank m2(p);
  m2.step(cmd, p.tau_s);
  EXPECT_NEAR(m2.speeds_radps()[0], m.speeds_radps()[0], 1e-9);
}

TEST(MotorBank, SaturatesCommandsAndSpeeds) {
  const RotorParams p;
  MotorBank m(p);
  RotorArray cmd;
  cmd.fill(2000.0);
  cmd[1] = -300.0;
  double max_seen = 0.0;
  for (int i = 0; i < 2000; ++i) {
    m.step(cmd, 1e-3);
    for (double w : m.speeds_radps()) max_seen = std::max(max_seen, w);
    EXPECT_GE(m.speeds_radps()[1], p.w_min_radps);
  }
  EXPECT_LE(max_seen, p.w_max_radps);
  EXPECT_NEAR(m.speeds_radps()[0], p.w_max_radps, 1e-6);
  EXPECT_EQ(m.speeds_radps()[1], p.w_min_radps);
  EXPECT_THROW(m.step(cmd, 0.0), std::invalid_argument);
}

// A small rigid-body integrator (vertical only, semi-implicit Euler at 1 kHz) driven by the
// rotor wrench: without thrust the body falls at g; at hover speed it stays put.
double fall_after(double w_radps, double T_s, double* accel_out) {
  const RotorParams p;
  const double dt = 1e-3;
  double z = 100.0, vz = 0.0;
  RotorArray ws;
  ws.fill(w_radps);
  for (int i = 0; i < static_cast<int>(std::lround(T_s / dt)); ++i) {
    const double az = rotor_wrench(p, ws).force_B_N.z() / kMass_kg - kG;
    *accel_out = az;
    vz += az * dt;
    z += vz * dt;
  }
  return 100.0 - z;
}

TEST(Rotor, FreeBodyWithoutThrustAcceleratesAtG) {
  double a = 0.0;
  const double drop = fall_after(0.0, 1.0, &a);
  EXPECT_DOUBLE_EQ(a, -kG);
  // Semi-implicit Euler overshoots 0.5 g t^2 by g dt t / 2 = 4.9 mm here.
  constexpr double kEulerTolerance_m = 0.01;
  EXPECT_NEAR(drop, 0.5 * kG, kEulerTolerance_m);
  const double hover_drop = fall_after(hover_speed_radps(RotorParams{}, kMass_kg, kG), 1.0, &a);
  EXPECT_NEAR(hover_drop, 0.0, 1e-6);
}

}  // namespace
}  // namespace lander::sim
