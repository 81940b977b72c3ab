// Altitude fusion (seed 004 sec. 4), ISA (eq. 8) and vision altitude (eq. 7) with exact,
// hand-made measurements. Tests with the sensor models live in tests/sim/fusion_*_test.cpp.
#include "lander/estimator/altitude_fusion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include "lander/estimator/altitude_vision.h"

namespace lander {
namespace {

using O = AltitudeFusion::Outcome;
constexpr double kDeg = M_PI / 180.0;

// --------------------------------------------------------------------- config (3 tests)
TEST(AltitudeFusionParams, DefaultIsValid) { EXPECT_NO_THROW(AltitudeFusionParams{}.validate()); }

TEST(AltitudeFusionParams, SaveLoadRoundTrip) {
  AltitudeFusionParams p;
  p.gate_factor_n = 0.25;
  p.max_sample_age_s = 0.3;
  p.step_count = 4;
  AltitudeFusionParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_EQ(q.gate_factor_n, 0.25);
  EXPECT_EQ(q.step_count, 4);
  EXPECT_DOUBLE_EQ(q.max_sample_age_s, 0.3);
}

TEST(AltitudeFusionParams, BadValueNamesField) {
  for (const auto& [yaml, field] : std::vector<std::pair<std::string, std::string>>{
           {"gate_factor_n: 1.5", "gate_factor_n"},
           {"step_count: 0", "step_count"},
           {"ultrasonic_max_m: 0.1", "ultrasonic_max_m"},
           {"baro_std_m: 0", "baro_std_m"}}) {
    AltitudeFusionParams p;
    try {
      read_params(YAML::Load(yaml), "f.yaml", p);
      FAIL() << "expected ConfigError for " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

// ------------------------------------------------------------------- ISA and vision
TEST(Isa, SeaLevelAndRoundTrip) {
  EXPECT_NEAR(isa_altitude_m(101325.0), 0.0, 1e-9);
  // ISA table: 11000 m (tropopause) -> 22632 Pa.
  constexpr double kTableTolerance_m = 1.0;  // table rounding
  EXPECT_NEAR(isa_altitude_m(22632.1), 11000.0, kTableTolerance_m);
  EXPECT_NEAR(isa_altitude_m(isa_pressure_pa(123.4)), 123.4, 1e-6);
  EXPECT_THROW(isa_altitude_m(0.0), std::invalid_argument);
  // ~12 Pa per metre near sea level: a 0.1 m resolution needs ~1 Pa.
  EXPECT_NEAR(isa_pressure_pa(0.0) - isa_pressure_pa(1.0), 12.0, 0.2);
}

TEST(VisionAltitude, Eq7) {
  // f = 640 px, L = 1 m imaged as 64 px: 10 m; tilted 10 deg pitch, 5 deg roll.
  EXPECT_DOUBLE_EQ(vision_altitude_m(640.0, 1.0, 64.0, 0.0, 0.0), 10.0);
  EXPECT_NEAR(vision_altitude_m(640.0, 1.0, 64.0, 10 * kDeg, 5 * kDeg),
              10.0 * std::cos(10 * kDeg) * std::cos(5 * kDeg), 1e-12);
  EXPECT_THROW(vision_altitude_m(640.0, 1.0, 0.0, 0.0, 0.0), std::invalid_argument);
}

TEST(VisionAltitude, HeightFromTargetPoseIsExactForAnyAttitude) {
  const Eigen::Isometry3d X_BC = CameraMount{}.X_BC();
  for (double roll_deg : {0.0, 10.0, -20.0}) {
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
                        .toRotationMatrix();
    X_WB.translation() = Eigen::Vector3d(0.4, -0.2, 5.8);
    Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
    X_WP.translation() = Eigen::Vector3d(0.0, 0.0, 0.8);  // platform top
    const Eigen::Isometry3d X_CP = X_BC.inverse() * X_WB.inverse() * X_WP;
    EXPECT_NEAR(height_above_target_m(X_CP, X_BC), 5.0, 1e-12) << roll_deg;
  }
  double roll, pitch;
  roll_pitch_rad(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX())),
                 &roll, &pitch);
  EXPECT_NEAR(roll, 0.05, 1e-12);
  EXPECT_NEAR(pitch, -0.1, 1e-12);
}

TEST(AltitudeFusion, VerticalAccelRemovesGravityInW) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
  ImuSample imu;
  imu.accel_B_mps2 = q.conjugate() * Eigen::Vector3d(0.2, 0.0, 9.81 + 1.5);
  EXPECT_NEAR(vertical_accel_W(imu, q, 9.81), 1.5, 1e-12);
}

// ------------------------------------------------------------------------ the filter
TEST(AltitudeFusion, PredictIntegratesAccelerationExactly) {
  AltitudeFusion f(AltitudeFusionParams{});
  f.reset(0.0, 1.0, 0.0);
  for (int k = 1; k <= 500; ++k) f.predict(k * 0.004, 0.5);  // 2 s at 0.5 m/s^2
  EXPECT_NEAR(f.estimate().z_W_m, 1.0 + 0.5 * 0.5 * 4.0, 1e-9);
  EXPECT_NEAR(f.estimate().vz_W_mps, 1.0, 1e-9);
  // Uncertainty grows with time.
  EXPECT_GT(f.estimate().var_m2, 0.05 * 0.05);
}

BaroSample baro_at(double t, double z_msl) {
  BaroSample b;
  b.t_s = t;
  b.pressure_pa = isa_pressure_pa(z_msl);
  return b;
}
UltrasonicSample us_at(double t, double r) {
  UltrasonicSample u;
  u.t_s = t;
  u.range_m = r;
  return u;
}

TEST(AltitudeFusion, MeasurementSetSwitchesAtThreeMetres) {
  AltitudeFusion high(AltitudeFusionParams{});
  high.reset(0.0, 10.0, 0.0);
  EXPECT_FALSE(high.ultrasonic_set_active());
  EXPECT_EQ(high.update_baro(baro_at(0.0, 10.0)), O::kAccepted);          // eq. 15
  EXPECT_EQ(high.update_ultrasonic(us_at(0.0, 2.0)), O::kRejectedSet);    // garbage (eq. 12)
  EXPECT_EQ(high.update_ultrasonic(us_at(0.0, 8.0)), O::kRejectedRange);  // beyond 3.05 m
  AltitudeFusion low(AltitudeFusionParams{});
  low.reset(0.0, 1.5, 0.0);
  EXPECT_TRUE(low.ultrasonic_set_active());
  EXPECT_EQ(low.update_baro(baro_at(0.0, 1.5)), O::kRejectedSet);        // eq. 17: no baro
  EXPECT_EQ(low.update_ultrasonic(us_at(0.0, 1.5)), O::kAccepted);
  EXPECT_EQ(low.update_ultrasonic(us_at(0.0, 0.1)), O::kRejectedRange);  // below 0.15 m
  EXPECT_EQ(low.update_ultrasonic(us_at(0.0, 3.2)), O::kRejectedRange);
  // Climbing out through 3.1 m switches back (hysteresis 0.1 m).
  for (int k = 1; k <= 1000 && low.ultrasonic_set_active(); ++k) low.predict(k * 0.004, 0.5);
  EXPECT_FALSE(low.ultrasonic_set_active());
  EXPECT_GT(low.estimate().h_surface_m, 3.1 - 1e-3);
}

TEST(AltitudeFusion, ConvergesBaroBiasFromExactMeasurements) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  f.reset(0.0, 10.0, 0.0);
  const double bias = 2.5;
  for (int k = 1; k <= 50 * 20; ++k) {  // 20 s at 50 Hz, vision at the same rate
    const double t = k * 0.02;
    f.predict(t, 0.0);
    f.update_baro(baro_at(t, 10.0 + bias));
    f.update_vision(t, 10.0 - p.platform_height_m, 0.05);
  }
  // Exact data: the bias is found to well under the baro noise the filter assumes.
  EXPECT_NEAR(f.estimate().baro_bias_m, bias, 0.01);
  EXPECT_NEAR(f.estimate().z_W_m, 10.0, 0.01);
}

TEST(AltitudeFusion, StartsInTheAirFromBaroWithUnknownBias) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  const double z_true = 10.0, bias = 1.5;
  f.reset_from_baro(baro_at(0.0, z_true + bias));
  EXPECT_NEAR(f.estimate().z_W_m, z_true + bias, 1e-6);
  // Var(z) is large, but z + eps_b is known: the covariance must be positive semi-definite.
  const Eigen::SelfAdjointEigenSolver<AltitudeFusion::Mat> es(f.P());
  EXPECT_GT(es.eigenvalues().minCoeff(), -1e-12);
  EXPECT_GT(f.estimate().var_m2, 1.0);
  // Vision (target plane known to 2 cm) sorts out the split within a second; nothing is
  // rejected as an outlier on the way (the 1.5 m disagreement is within the prior).
  for (int k = 1; k <= 30; ++k) {
    const double t = k / 30.0;
    f.predict(t, 0.0);
    EXPECT_NE(f.update_vision(t, z_true - p.platform_height_m, 0.05), O::kRejectedOutlier);
    if (k % 2 == 0) f.update_baro(baro_at(t, z_true + bias));
  }
  // Vision at 5 cm / 30 Hz for 1 s plus the 2 cm plane prior: a few cm.
  constexpr double kSettled_m = 0.05;
  EXPECT_NEAR(f.estimate().z_W_m, z_true, kSettled_m);
  EXPECT_NEAR(f.estimate().baro_bias_m, bias, kSettled_m);
}

TEST(AltitudeFusion, GpsOutlierIsGatedEq27) {
  AltitudeFusionParams p;
  AltitudeFusionParams p1 = p;
  p1.gate_factor_n = 1.0;
  AltitudeFusion a(p), b(p1);
  a.reset(0.0, 10.0, 0.0);
  b.reset(0.0, 10.0, 0.0);
  GpsSample g;
  g.t_s = 0.0;
  g.p_W_m = Eigen::Vector3d(0, 0, 10.0 + 4.0);  // ~3.3 sqrt(P~): beyond 2, within 5
  EXPECT_EQ(a.update_gps(g), O::kGated);
  EXPECT_EQ(b.update_gps(g), O::kGated);  // also beyond the gate, but full gain (n = 1)
  EXPECT_GT(b.estimate().z_W_m - 10.0, 1e-3);
  EXPECT_NEAR(a.estimate().z_W_m - 10.0, p.gate_factor_n * (b.estimate().z_W_m - 10.0), 1e-9);
  // A very large residual (> reject_sigma sqrt(P~)) gets no gain at all (sec. 4.3) ...
  const double z_before = a.estimate().z_W_m;
  g.p_W_m.z() = 10.0 + 20.0;
  EXPECT_EQ(a.update_gps(g), O::kRejectedOutlier);
  EXPECT_EQ(a.estimate().z_W_m, z_before);
  // ... until reject_limit of them in a row: then n K again (no lock-out).
  for (int k = 1; k < p.reject_limit; ++k) EXPECT_EQ(a.update_gps(g), O::kRejectedOutlier);
  EXPECT_EQ(a.update_gps(g), O::kGated);
  EXPECT_GT(a.estimate().z_W_m, z_before);
  g.p_W_m.z() = a.estimate().z_W_m + 0.5;  // within 2 sqrt(P~)
  EXPECT_EQ(a.update_gps(g), O::kAccepted);
  g.valid = false;
  EXPECT_EQ(a.update_gps(g), O::kRejectedRange);
}

TEST(AltitudeFusion, StaleAndFutureSamplesAreRejected) {
  AltitudeFusion f(AltitudeFusionParams{});
  f.reset(10.0, 10.0, 0.0);
  EXPECT_EQ(f.update_baro(baro_at(9.0, 10.0)), O::kRejectedStale);   // 1 s old > 0.5 s
  EXPECT_EQ(f.update_baro(baro_at(10.5, 10.0)), O::kRejectedStale);  // from the future
  EXPECT_EQ(f.update_baro(baro_at(9.8, 10.0)), O::kAccepted);
}

TEST(AltitudeFusion, PlatformEdgeReReferencesSurfaceNotHeight) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  f.reset(0.0, 2.0, 0.0);
  double t = 0.0;
  for (int k = 0; k < 20; ++k) {  // 1 s over the ground at 2 m
    t += 0.05;
    f.predict(t, 0.0);
    EXPECT_EQ(f.update_ultrasonic(us_at(t, 2.0)), O::kAccepted);
  }
  const double z_before = f.estimate().z_W_m;
  // Over the platform: 1.2 m. step_count - 1 pings are held, then the surface moves.
  for (int k = 0; k < p.step_count; ++k) {
    t += 0.05;
    f.predict(t, 0.0);
    EXPECT_EQ(f.update_ultrasonic(us_at(t, 1.2)), k + 1 < p.step_count ? O::kStepPending
                                                                       : O::kSurfaceStep);
    EXPECT_NEAR(f.estimate().z_W_m, z_before, 1e-9);  // the height in W never moves
  }
  EXPECT_NEAR(f.estimate().h_surface_m, 1.2, 1e-6);
  t += 0.05;
  f.predict(t, 0.0);
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 1.2)), O::kAccepted);
  // Two garbage values that disagree never make a step.
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 2.5)), O::kStepPending);
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 0.4)), O::kStepPending);
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 2.9)), O::kStepPending);
  EXPECT_NEAR(f.estimate().h_surface_m, 1.2, 1e-6);
  // After garbage, readings at the right height must pass step_count times in a row.
  for (int k = 0; k < p.step_count; ++k) {
    EXPECT_EQ(f.update_ultrasonic(us_at(t, 1.2)), k + 1 < p.step_count ? O::kStepPending
                                                                       : O::kAccepted);
  }
}

TEST(AltitudeFusion, AcquiresUnknownSurfaceComingDownIntoRange) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  f.reset(0.0, 3.5, 0.0);  // believes the ground is below; it is the platform (0.8 m)
  EXPECT_FALSE(f.ultrasonic_set_active());
  double t = 0.0;
  O last = O::kRejectedSet;
  for (int k = 0; k < p.step_count; ++k) {
    t += 0.05;
    f.predict(t, 0.0);
    last = f.update_ultrasonic(us_at(t, 2.7));
  }
  EXPECT_EQ(last, O::kSurfaceStep);
  EXPECT_TRUE(f.ultrasonic_set_active());
  EXPECT_NEAR(f.estimate().h_surface_m, 2.7, 1e-6);
  EXPECT_NEAR(f.estimate().z_W_m, 3.5, 1e-9);
}

// A degraded GPS's vertical error taken in at the start: the filter believes 4.5 m over the
// ground, the vehicle is at 1.2 m (a flown campaign run went down to 0.94 m like this while
// its search held "4.5 m"). In-range readings that imply a 3.3 m step are garbage on their
// own; height_reset_count of them that agree set the height from them over the believed
// ground, with the barometer's and the GPS's predictions unchanged; the eq. 17 set is then
// in force and the next reading is accepted.
TEST(AltitudeFusion, AgreeingRangeReadingsResetAHeightThatIsWrong) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  f.reset(0.0, 4.5, 0.0);
  const AltitudeEstimate e0 = f.estimate();
  double t = 0.0;
  for (int k = 0; k < p.height_reset_count; ++k) {
    t += 0.05;
    f.predict(t, 0.0);
    const O o = f.update_ultrasonic(us_at(t, 1.2 + (k % 2 ? 0.003 : -0.003)));
    if (k + 1 < p.height_reset_count) {
      EXPECT_EQ(o, O::kRejectedSet) << k;
      EXPECT_NEAR(f.estimate().z_W_m, 4.5, 1e-9);
    } else {
      EXPECT_EQ(o, O::kHeightReset);
    }
  }
  const AltitudeEstimate e1 = f.estimate();
  // The readings' mean, 1.2 m, over the believed ground (0): within the readings' spread.
  EXPECT_NEAR(e1.z_W_m, 1.2, 0.003);
  EXPECT_NEAR(e1.h_surface_m, 1.2, 0.003);
  EXPECT_EQ(f.height_resets(), 1);
  EXPECT_TRUE(f.ultrasonic_set_active());
  // The barometer reads z + b: its prediction did not move, the bias took the 3.3 m.
  EXPECT_NEAR(e1.z_W_m + e1.baro_bias_m, e0.z_W_m + e0.baro_bias_m, 1e-9);
  EXPECT_NEAR(e1.baro_bias_m - e0.baro_bias_m, 3.3, 0.003);
  // The height's variance is the believed surface's plus the readings' (their mean is good to
  // a millimetre): a few centimetres, not the 3.3 m it was off.
  EXPECT_LT(std::sqrt(e1.var_m2), 0.1);
  t += 0.05;
  f.predict(t, 0.0);
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 1.2)), O::kAccepted);
}

// In-range values that do not agree (eq. 12's garbage falls inside the range a third of the
// time) never reset the height nor give a clearance, nor does a run one reading short of
// height_reset_count reset it.
TEST(AltitudeFusion, GarbageAndShortRunsNeverResetTheHeight) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  f.reset(0.0, 6.0, 0.0);
  double t = 0.0;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> in_range(p.ultrasonic_min_m, p.ultrasonic_max_m);
  for (int k = 0; k < 2000; ++k) {
    t += 0.05;
    f.predict(t, 0.0);
    EXPECT_NE(f.update_ultrasonic(us_at(t, in_range(rng))), O::kHeightReset);
    EXPECT_FALSE(std::isfinite(f.estimate().clearance_m)) << k;
  }
  for (int run = 0; run < 3; ++run) {
    for (int k = 0; k + 1 < p.height_reset_count; ++k) {
      t += 0.05;
      f.predict(t, 0.0);
      EXPECT_EQ(f.update_ultrasonic(us_at(t, 1.0)), O::kRejectedSet);
    }
    t += 0.05;
    f.predict(t, 0.0);
    EXPECT_EQ(f.update_ultrasonic(us_at(t, 1e6)), O::kRejectedRange);  // breaks the run
  }
  EXPECT_EQ(f.height_resets(), 0);
  EXPECT_NEAR(f.estimate().z_W_m, 6.0, 1e-6);
}

// The far-start campaign's ground contact (seed 83117, run 0014): a GPS error of metres taken
// in at the start put the believed height at 1.8 m while the vehicle flew at 6 m. The eq. 17
// set then drops the barometer for the ultrasonic, which sees nothing in range up there; the
// GPS alone (its error wandering with it) carried the height, and a 3 m/s descent went
// unseen until the gear hit the ground. baro_fallback_s after the set came in force with no
// trusted reading, the barometer is fused again. Here the vehicle descends 2 m (the IMU's
// acceleration exact) while the GPS reads a constant height (its error growing by the
// descent, as a 10 s Gauss-Markov error can): with the fallback the fused height follows the
// barometer down; with it off (the paper's switch as is) it stays with the GPS.
struct DescentSeen {
  double descent_m{0.0};       // fused height's change over the 2 s descent (truly 2 m)
  double max_vz_error_mps{0.0};  // worst fused vertical velocity error in it
  long fallbacks{0};
};
DescentSeen descent_seen(double baro_fallback_s) {
  AltitudeFusionParams p;
  p.baro_fallback_s = baro_fallback_s;
  AltitudeFusion f(p);
  constexpr double kBelieved_m = 1.8, kTrue0_m = 6.0;
  f.reset(0.0, kBelieved_m, 0.0, 0.0, 1.5);
  EXPECT_TRUE(f.ultrasonic_set_active());
  double z = kTrue0_m, vz = 0.0;
  DescentSeen out;
  double z_fused_before = 0.0;
  const double dt = 0.004;
  for (int k = 1; k <= 1250; ++k) {  // 5 s
    const double t = k * dt;
    const double a = (t > 3.0 && t <= 4.0) ? -2.0 : (t > 4.0 && t <= 5.0) ? 2.0 : 0.0;
    z += vz * dt + 0.5 * a * dt * dt;
    vz += a * dt;
    f.predict(t, a);
    if (k % 5 == 0) f.update_baro(baro_at(t, z));
    if (k % 50 == 0) {
      GpsSample g;
      g.t_s = t;
      g.p_W_m = Eigen::Vector3d(0.0, 0.0, kBelieved_m);
      f.update_gps(g);
    }
    if (k % 12 == 0) f.update_ultrasonic(us_at(t, 1e6));  // nothing in range
    if (k == 750) z_fused_before = f.estimate().z_W_m;  // t = 3 s
    if (t > 3.0) {
      out.max_vz_error_mps = std::max(out.max_vz_error_mps, std::abs(f.estimate().vz_W_mps - vz));
    }
  }
  EXPECT_NEAR(z, kTrue0_m - 2.0, 1e-9);
  out.descent_m = z_fused_before - f.estimate().z_W_m;
  out.fallbacks = f.baro_fallback_updates();
  return out;
}

TEST(AltitudeFusion, BarometerReturnsWhileTheRangerSeesNothingInItsSet) {
  const DescentSeen with = descent_seen(1.0);
  const DescentSeen without = descent_seen(0.0);
  // Every 50 Hz barometer sample from t = 1 s (baro_fallback_s after the set came in force).
  EXPECT_NEAR(with.fallbacks, 200, 1);
  EXPECT_EQ(without.fallbacks, 0);
  // The IMU's acceleration is exact and the barometer noise-free: the velocity is seen to
  // centimetres per second. Without the barometer the flat GPS pulled it 0.9 m/s off.
  constexpr double kVzTolerance_mps = 0.05;
  EXPECT_LT(with.max_vz_error_mps, kVzTolerance_mps);
  EXPECT_GT(without.max_vz_error_mps, 0.5);
  // The height's change: the barometer pins z + b, the flat GPS moves the split between them
  // as the filter's own GPS model (1.2 m, 10 s) allows, so part of the 2 m goes to the bias
  // (1.48 m seen); without the barometer none is seen.
  constexpr double kMinDescentSeen_m = 1.2;
  EXPECT_GT(with.descent_m, kMinDescentSeen_m);
  EXPECT_LT(std::abs(without.descent_m), 0.2);
}

// The clearance (the controller's floor in the search): only clearance_count readings in a
// row whose implied surfaces agree give one (garbage never does: above); readings taken
// while descending at 1.5 m/s agree (7.5 cm apart, beyond step_agree_m as raw heights); one
// reading out of range ends it. The same chain resets a height that is wrong by 2.5 m during
// that descent.
TEST(AltitudeFusion, ClearanceAndHeightResetFromAgreeingReadingsAlsoInADescent) {
  AltitudeFusionParams p;
  AltitudeFusion f(p);
  // Believed 5.5 m, truly 3.0 m, both descending at 1.5 m/s (the IMU gives the motion).
  constexpr double kVz_mps = -1.5;
  double t = 0.0;
  f.reset(t, 5.5, 0.0, kVz_mps);
  double h = 3.0;
  int resets_at = -1;
  for (int k = 0; k < p.height_reset_count; ++k) {
    t += 0.05;
    h += kVz_mps * 0.05;
    f.predict(t, 0.0);
    const O o = f.update_ultrasonic(us_at(t, h));
    if (o == O::kHeightReset) resets_at = k;
    const double c = f.estimate().clearance_m;
    if (k + 1 < p.clearance_count) {
      EXPECT_FALSE(std::isfinite(c)) << k;
    } else if (o != O::kHeightReset) {
      EXPECT_NEAR(c, h, 1e-6) << k;  // exact readings, exact motion
      EXPECT_NEAR(f.estimate().h_surface_m, h + 2.5, 1e-6) << k;  // not yet reset
    }
  }
  EXPECT_EQ(resets_at, p.height_reset_count - 1);
  EXPECT_NEAR(f.estimate().h_surface_m, h, 1e-6);
  EXPECT_NEAR(f.estimate().clearance_m, h, 1e-6);
  t += 0.05;
  f.predict(t, 0.0);
  EXPECT_EQ(f.update_ultrasonic(us_at(t, 1e6)), O::kRejectedRange);
  EXPECT_FALSE(std::isfinite(f.estimate().clearance_m));
}

}  // namespace
// A moving surface (issue 56): the vehicle hovers still at 2 m over a deck heaving 0.3 m
// with a 6 s period (peak vertical speed 0.31 m/s), ultrasonic at 20 Hz and barometer at
// 50 Hz, both with noise; IMU exact (0 vertical acceleration). Seed 004's still surface puts
// the heave into the height and its velocity; moving_surface_rw_mps keeps them on the
// vehicle (truth: z = 2, vz = 0) while the height over the deck still follows the ranger.
struct HeaveSeen {
  double max_vz_err_mps{0.0};   // |fused vz - 0| after the first 10 s
  double max_h_err_m{0.0};      // |fused height over the surface - true| after the first 10 s
};
HeaveSeen hover_over_heaving_deck(double moving_surface_rw_mps) {
  AltitudeFusionParams p;
  p.moving_surface_rw_mps = moving_surface_rw_mps;
  AltitudeFusion f(p);
  f.reset(0.0, 2.0, 0.0);
  std::mt19937 rng(56);
  std::normal_distribution<double> baro_noise(0.0, 0.1), us_noise(0.0, 0.005);
  constexpr double kHeave_m = 0.3, kPeriod_s = 6.0, kZ_m = 2.0;
  HeaveSeen seen;
  for (int k = 1; k <= 200 * 40; ++k) {  // 40 s, 200 Hz IMU
    const double t = k * 0.005;
    const double deck = kHeave_m * std::sin(2.0 * M_PI * t / kPeriod_s);
    f.predict(t, 0.0);
    if (k % 4 == 0) f.update_baro(baro_at(t, kZ_m + baro_noise(rng)));
    if (k % 10 == 0) f.update_ultrasonic(us_at(t, kZ_m - deck + us_noise(rng)));
    if (t > 10.0) {
      const AltitudeEstimate e = f.estimate();
      seen.max_vz_err_mps = std::max(seen.max_vz_err_mps, std::abs(e.vz_W_mps));
      seen.max_h_err_m = std::max(seen.max_h_err_m, std::abs(e.h_surface_m - (kZ_m - deck)));
    }
  }
  return seen;
}

TEST(AltitudeFusion, AMovingSurfaceStaysOutOfTheHeightAndItsVelocity) {
  const HeaveSeen still = hover_over_heaving_deck(0.0);
  const HeaveSeen moving = hover_over_heaving_deck(1.0);
  // Still-surface model: the heave's velocity (peak 0.31 m/s) goes into vz whole (observed
  // 0.33 m/s; floor 0.25 m/s, most of the peak).
  EXPECT_GT(still.max_vz_err_mps, 0.25);
  // Moving-surface model: the barometer (0.1 m noise) and the IMU hold vz (observed
  // 0.053 m/s; bound 0.08 m/s, a quarter of the heave's peak speed).
  EXPECT_LT(moving.max_vz_err_mps, 0.08);
  // ... and the height over the deck still follows the ranger (observed 2.9 cm at worst,
  // between readings: the deck moves up to 1.6 cm in the ranger's 50 ms, which a random walk
  // does not predict; bound 4 cm).
  EXPECT_LT(moving.max_h_err_m, 0.04);
}

}  // namespace lander
