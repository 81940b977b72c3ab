// Altitude fusion (seed 004 sec. 4) driven by the sensor models along analytic trajectories:
// converges from a wrong baro bias, rejects a GPS step by gating (eq. 27), ignores
// out-of-range ultrasonic values (eq. 12), survives the platform-edge jump, and beats the
// single sensors on a descent onto the platform.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <functional>
#include <iostream>
#include <map>
#include <random>

#include "lander/estimator/altitude_fusion.h"
#include "lander/sim/recorder/altitude_metrics.h"
#include "lander/sim/sensors/sensors.h"

namespace lander::sim {
namespace {

// Runs use seed 1 unless LANDER_TEST_SEED is set (to check that a pass is not one lucky draw:
// for s in $(seq 1 40); do LANDER_TEST_SEED=$s ./fusion_..._test; done).
std::uint64_t seed_from_env() {
  const char* s = std::getenv("LANDER_TEST_SEED");
  return s ? std::stoull(s) : 1;
}

constexpr double kPlatformTop_m = 0.8;  // platform top above the ground (project facts)

struct Flight {
  std::function<double(double)> z;        // height of B in W (m) at t
  std::function<double(double)> x;        // horizontal position (m) at t
  std::function<double(double)> surface;  // surface height (m) below horizontal position x
  double duration_s{60.0};
  bool vision{true};
  double vision_std_m{0.05};
  double vision_outlier_prob{0.0};   // probability of a gross vision error (wrong contour)
  double vision_outlier_m{2.0};      // its size (m)
  SensorSuiteParams sensors;
  AltitudeFusionParams fusion;
  double init_z_m{10.0};        // filter start
  double init_surface_m{0.0};
  std::function<void(GpsModel&, UltrasonicModel&)> faults;
  std::uint64_t seed{seed_from_env()};
};

struct Result {
  std::vector<double> t, z_err, h_err, h_true;
  std::map<AltitudeFusion::Outcome, int> us_outcomes;
  std::vector<std::pair<double, AltitudeFusion::Outcome>> us_log;  // (sample time, outcome)
  std::vector<std::pair<double, AltitudeFusion::Outcome>> gps_outcomes;
  double baro_bias_err_end{0};
  double baro_bias_std_end{0};     // the filter's own sqrt(P_bb) at the end
  std::vector<double> z_std;       // the filter's own sqrt(P_zz), per record
  std::vector<double> h_std;       // the filter's own std of z - s, per record
  AltitudeMetrics metrics;
  // Max |error| over t in [t0, t1).
  double max_abs(const std::vector<double>& e, double t0, double t1) const {
    double m = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t[i] >= t0 && t[i] < t1) m = std::max(m, std::abs(e[i]));
    }
    return m;
  }
};

// Truth at t from the analytic trajectory (derivatives by central differences).
VehicleTruth truth_at(const Flight& f, double t) {
  constexpr double d = 1e-4;
  VehicleTruth tr;
  tr.t_s = t;
  const double z = f.z(t);
  tr.X_WB.translation() = Eigen::Vector3d(f.x(t), 0.0, z);
  tr.v_W_mps = Eigen::Vector3d((f.x(t + d) - f.x(t - d)) / (2 * d), 0.0,
                               (f.z(t + d) - f.z(t - d)) / (2 * d));
  tr.a_W_mps2 = Eigen::Vector3d((f.x(t + d) - 2 * f.x(t) + f.x(t - d)) / (d * d), 0.0,
                                (f.z(t + d) - 2 * z + f.z(t - d)) / (d * d));
  tr.h_surface_m = z - f.surface(f.x(t));
  tr.range_m = tr.h_surface_m;  // level: the ray goes straight down
  tr.thrust_fraction = 0.5;
  return tr;
}

Result fly(const Flight& f) {
  ImuModel imu(f.sensors.imu, f.seed * 10 + 1);
  BaroModel baro(f.sensors.baro, f.seed * 10 + 2);
  GpsModel gps(f.sensors.gps, f.seed * 10 + 3);
  UltrasonicModel us(f.sensors.ultrasonic, f.seed * 10 + 4);
  if (f.faults) f.faults(gps, us);
  std::mt19937_64 vrng(f.seed * 10 + 5);
  std::normal_distribution<double> vn(0.0, f.vision_std_m);
  std::mt19937_64 orng(f.seed * 10 + 6);  // own stream: outliers leave the noise unchanged
  std::uniform_real_distribution<double> vu(0.0, 1.0);
  DelayQueue<BaroSample> qb;
  DelayQueue<GpsSample> qg;
  DelayQueue<UltrasonicSample> qu;
  DelayQueue<std::pair<double, double>> qv;  // (t, h_plane)
  RateClock vision_clock(30.0);
  constexpr double kVisionLatency_s = 0.1;

  AltitudeFusion fus(f.fusion);
  fus.reset(0.0, f.init_z_m, f.init_surface_m);
  Result res;
  const double dt = 1e-3;
  const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
  for (int k = 0; k <= static_cast<int>(std::lround(f.duration_s / dt)); ++k) {
    const double t = k * dt;
    const VehicleTruth tr = truth_at(f, t);
    const double z = tr.X_WB.translation().z();
    if (imu.due(t)) fus.predict(imu.sample(tr), level);
    if (baro.due(t)) qb.push(baro.sample(tr), t + f.sensors.baro.latency_s);
    if (gps.due(t)) qg.push(gps.sample(tr), t + f.sensors.gps.latency_s);
    if (us.due(t)) qu.push(us.sample(tr), t + f.sensors.ultrasonic.latency_s);
    if (f.vision && vision_clock.due(t)) {
      vision_clock.advance(t);
      double h_v = z - kPlatformTop_m + vn(vrng);
      if (vu(orng) < f.vision_outlier_prob) h_v += f.vision_outlier_m;
      qv.push({t, h_v}, t + kVisionLatency_s);
    }
    for (const auto& s : qb.pop_ready(t)) {
      fus.update_baro(s);
      res.metrics.add("baro", isa_altitude_m(s.pressure_pa) - f.fusion.baro_origin_msl_m -
                                  truth_at(f, s.t_s).X_WB.translation().z(),
                      truth_at(f, s.t_s).h_surface_m);
    }
    for (const auto& s : qg.pop_ready(t)) {
      res.gps_outcomes.push_back({s.t_s, fus.update_gps(s)});
      if (s.valid) {
        const VehicleTruth ts = truth_at(f, s.t_s);
        res.metrics.add("gps", s.p_W_m.z() - ts.X_WB.translation().z(), ts.h_surface_m);
      }
    }
    for (const auto& s : qu.pop_ready(t)) {
      const AltitudeFusion::Outcome o = fus.update_ultrasonic(s);
      ++res.us_outcomes[o];
      res.us_log.push_back({s.t_s, o});
      const VehicleTruth ts = truth_at(f, s.t_s);
      if (ts.range_m >= f.sensors.ultrasonic.min_range_m &&
          ts.range_m <= f.sensors.ultrasonic.max_range_m) {
        res.metrics.add("ultrasonic", s.range_m - ts.range_m, ts.h_surface_m);
      }
    }
    for (const auto& v : qv.pop_ready(t)) {
      fus.update_vision(v.first, v.second, f.vision_std_m);
      const VehicleTruth ts = truth_at(f, v.first);
      res.metrics.add("vision", v.second - (ts.X_WB.translation().z() - kPlatformTop_m),
                      ts.h_surface_m);
    }
    if (k % 20 == 0) {  // record at 50 Hz
      const AltitudeEstimate e = fus.estimate();
      res.t.push_back(t);
      res.z_err.push_back(e.z_W_m - z);
      res.h_err.push_back(e.h_surface_m - tr.h_surface_m);
      res.h_true.push_back(tr.h_surface_m);
      res.z_std.push_back(std::sqrt(e.var_m2));
      {
        using F = AltitudeFusion;
        const auto& P = fus.P();
        res.h_std.push_back(std::sqrt(P(F::kZ, F::kZ) + P(F::kSurface, F::kSurface) -
                                      2 * P(F::kZ, F::kSurface)));
      }
      if (t > 5.0) {
        // The fused estimate against what matters in each band: height in W above 3 m,
        // height above the surface below 3 m (what the landing needs).
        res.metrics.add("fused", tr.h_surface_m >= 3.0 ? e.z_W_m - z : e.h_surface_m - tr.h_surface_m,
                        tr.h_surface_m);
      }
    }
  }
  res.baro_bias_err_end = fus.estimate().baro_bias_m - (baro.bias_m() + baro.drift_m());
  res.baro_bias_std_end = std::sqrt(fus.P()(AltitudeFusion::kBaroBias, AltitudeFusion::kBaroBias));
  return res;
}

Flight hover(double z) {
  Flight f;
  f.z = [z](double) { return z; };
  f.x = [](double) { return 0.0; };
  f.surface = [](double) { return 0.0; };
  f.init_z_m = z;
  return f;
}

TEST(FusionAltitude, ConvergesFromWrongInitialBaroBias) {
  Flight f = hover(10.0);
  f.sensors.baro.bias_mean_m = 3.0;  // filter starts at 0 with std 3 m
  f.sensors.baro.bias_std_m = 0.0;
  const Result r = fly(f);
  // Converged: the filter is sure of the bias to a few cm (vision pins z relative to the
  // platform, whose height is known to 2 cm) ...
  constexpr double kConvergedStd_m = 0.05;
  EXPECT_LT(r.baro_bias_std_end, kConvergedStd_m);
  // ... and right about it: the error (from 3 m at the start) is within 3 of its own sigma.
  constexpr double kConsistencySigmas = 3.0;
  EXPECT_LT(std::abs(r.baro_bias_err_end), kConsistencySigmas * r.baro_bias_std_end);
  std::cout << "baro bias error " << r.baro_bias_err_end << " m, filter sigma "
            << r.baro_bias_std_end << " m\n";
  // After 5 s the height in W stays within 3 sigma of the vision noise.
  constexpr double kHeightTolerance_m = 0.15;
  EXPECT_LT(r.max_abs(r.z_err, 5.0, 60.0), kHeightTolerance_m);
  // No ultrasonic value used at 10 m.
  EXPECT_EQ(r.us_outcomes.count(AltitudeFusion::Outcome::kAccepted), 0u);
}

TEST(FusionAltitude, RejectsGpsStepByGating) {
  // Baro + GPS only (no vision): the GPS has the most weight here, the hardest case.
  // The deviation caused by the fault is measured against the same run without it.
  auto run = [](double n, bool fault) {
    Flight f = hover(10.0);
    f.vision = false;
    f.fusion.gate_factor_n = n;
    if (n == 1.0) f.fusion.reject_sigma = 1e9;  // no gating at all: the plain linear filter
    if (fault) {
      f.faults = [](GpsModel& g, UltrasonicModel&) { g.inject_offset(30.0, 2.0, {0, 0, 5.0}); };
    }
    return fly(f);
  };
  auto deviation = [](const Result& a, const Result& b) {
    double m = 0;
    for (std::size_t i = 0; i < a.t.size(); ++i) {
      m = std::max(m, std::abs(a.z_err[i] - b.z_err[i]));
    }
    return m;
  };
  const double n = AltitudeFusionParams{}.gate_factor_n;
  const Result gated = run(n, true);
  // Every fix of the step is gated (eq. 27: n K) or, when very large, dropped (K* = 0).
  int in_step = 0;
  for (const auto& o : gated.gps_outcomes) {
    if (o.first >= 30.0 && o.first < 32.0) {
      ++in_step;
      EXPECT_TRUE(o.second == AltitudeFusion::Outcome::kGated ||
                  o.second == AltitudeFusion::Outcome::kRejectedOutlier)
          << o.first;
    }
  }
  EXPECT_EQ(in_step, 10);  // 2 s at 5 Hz
  // Deviation through the fault: the target is < 0.1 m.
  const double dev = deviation(gated, run(n, false));
  const double dev_ungated = deviation(run(1.0, true), run(1.0, false));
  constexpr double kFaultDeviation_m = 0.1;
  EXPECT_LT(dev, kFaultDeviation_m);
  // Gating is what does it: the plain Kalman filter (n = 1, no rejection) is moved more by
  // the same step. (Not by 1/n: with gating, the clean run's own gated fixes and the
  // fault run's dropped ones also differ.)
  EXPECT_GT(dev_ungated, 2.0 * dev);
  std::cout << "GPS +5 m step: deviation gated " << dev << " m, ungated " << dev_ungated
            << " m\n";
}

TEST(FusionAltitude, VisionOutliersAreGated) {
  // 10 % of the vision heights off by +2 m (a wrong contour), at 10 m and at 2 m. The
  // deviation they cause, against the same run without them, stays under the issue's
  // 0.1 m fault target.
  for (double z : {10.0, 2.0}) {
    Flight clean = hover(z);
    Flight faulty = hover(z);
    faulty.vision_outlier_prob = 0.1;
    const Result a = fly(clean), b = fly(faulty);
    double dev = 0;
    for (std::size_t i = 0; i < a.t.size(); ++i) {
      dev = std::max(dev, std::abs(a.z_err[i] - b.z_err[i]));
      dev = std::max(dev, std::abs(a.h_err[i] - b.h_err[i]));
    }
    constexpr double kFaultDeviation_m = 0.1;
    EXPECT_LT(dev, kFaultDeviation_m) << "at " << z << " m";
    std::cout << "vision outliers at " << z << " m: deviation " << dev << " m\n";
  }
}

TEST(FusionAltitude, IgnoresOutOfRangeUltrasonicValues) {
  // At 10 m every ultrasonic value is garbage (eq. 12), a third of it inside 0.15-3 m.
  Flight high = hover(10.0);
  const Result r = fly(high);
  using O = AltitudeFusion::Outcome;
  EXPECT_EQ(r.us_outcomes.count(O::kAccepted) + r.us_outcomes.count(O::kGated) +
                r.us_outcomes.count(O::kSurfaceStep),
            0u);
  // 60 s at 20 Hz, all rejected: out of the valid range, or not in the active set.
  EXPECT_EQ(r.us_outcomes.at(O::kRejectedSet) + r.us_outcomes.at(O::kRejectedRange), 1200);
  // At 2 m with garbage bursts (1 s each): no garbage value is applied; they are rejected
  // (out of range) or held (step detector / re-confirmation).
  Flight low = hover(2.0);
  const double bursts[3] = {10.0, 20.0, 30.0};
  low.faults = [&](GpsModel&, UltrasonicModel& u) {
    for (double b : bursts) u.inject_garbage(b, 1.0);
  };
  Result rl = fly(low);
  auto in_burst = [&](double t, double extra) {
    for (double b : bursts) {
      if (t >= b && t < b + 1.0 + extra) return true;
    }
    return false;
  };
  int garbage_seen = 0;
  for (const auto& o : rl.us_log) {
    if (!in_burst(o.first, 0.0)) continue;
    ++garbage_seen;
    if (o.second == O::kRejectedRange || o.second == O::kStepPending) continue;
    // Only the first garbage value of a burst can be used, and only when it happens to fall
    // inside the 2-sigma gate (~1 cm here; indistinguishable from a good reading). Every
    // later one meets the re-confirmation rule.
    double since_start = 1e9;
    for (double b : bursts) {
      if (o.first >= b) since_start = std::min(since_start, o.first - b);
    }
    EXPECT_LT(since_start, 1.0 / low.sensors.ultrasonic.rate_hz - 1e-9)
        << "garbage at t = " << o.first << " was used";
    EXPECT_TRUE(o.second == O::kAccepted || o.second == O::kGated);  // gated: n K, < 1 cm
  }
  EXPECT_EQ(garbage_seen, 60);  // 3 bursts x 1 s x 20 Hz
  EXPECT_EQ(rl.us_outcomes[O::kSurfaceStep], 0);
  // Outside the bursts (and 3 pings + latency after them) the height above the surface has
  // ultrasonic accuracy; the target is 0.02 m below 3 m.
  constexpr double kLowTolerance_m = 0.02;
  constexpr double kRecovery_s = 0.3;
  double max_out = 0, ss = 0;
  constexpr double kConsistencySigmas = 4.0;
  for (std::size_t i = 0; i < rl.t.size(); ++i) {
    if (rl.t[i] < 2.0) continue;
    ss += rl.h_err[i] * rl.h_err[i];
    if (in_burst(rl.t[i], kRecovery_s)) {
      // Inside a burst the filter coasts (IMU, with vision and GPS moving z): its error
      // grows, and so does its own sigma; the error stays within 4 of them.
      EXPECT_LT(std::abs(rl.h_err[i]), kConsistencySigmas * rl.h_std[i]) << rl.t[i];
    } else {
      max_out = std::max(max_out, std::abs(rl.h_err[i]));
    }
  }
  EXPECT_LT(max_out, kLowTolerance_m);
  EXPECT_LT(std::sqrt(ss / rl.t.size()), kLowTolerance_m);
}

TEST(FusionAltitude, SurvivesPlatformEdgeWithoutSpike) {
  // 2 m above the ground, flying over the platform edge (x = 0) at 0.5 m/s and back.
  Flight f = hover(2.0);
  f.duration_s = 40.0;
  f.x = [](double t) { return t < 20.0 ? -5.0 + 0.5 * t : 5.0 - 0.5 * (t - 20.0); };
  f.surface = [](double x) { return x >= 0.0 ? kPlatformTop_m : 0.0; };
  const Result r = fly(f);
  Flight flat = f;  // the same flight (same noise) over flat ground
  flat.surface = [](double) { return 0.0; };
  const Result r0 = fly(flat);
  // Height in W: what the crossings change against the flat run stays under the issue's
  // 0.1 m fault target. (It is not zero: over the platform z loses the ground reference
  // and rests on vision, the platform's known height and GPS.)
  constexpr double kCrossingDeviation_m = 0.1;
  double dev = 0;
  for (std::size_t i = 0; i < r.t.size(); ++i) dev = std::max(dev, std::abs(r.z_err[i] - r0.z_err[i]));
  EXPECT_LT(dev, kCrossingDeviation_m);
  // And the filter knows how good z is: the error stays within 4 of its own sigma.
  constexpr double kConsistencySigmas = 4.0;
  for (std::size_t i = 0; i < r.t.size(); ++i) {
    if (r.t[i] >= 2.0) {
      EXPECT_LT(std::abs(r.z_err[i]), kConsistencySigmas * r.z_std[i]) << r.t[i];
    }
  }
  std::cout << "platform edge: z deviation from flat run " << dev << " m\n";
  // Height above the surface follows the true jump after the step detector's delay
  // (3 pings at 20 Hz + 10 ms latency < 0.3 s).
  constexpr double kDetectDelay_s = 0.3;
  constexpr double kLowTolerance_m = 0.02;
  EXPECT_LT(r.max_abs(r.h_err, 2.0, 10.0), kLowTolerance_m);
  EXPECT_LT(r.max_abs(r.h_err, 10.0 + kDetectDelay_s, 30.0), kLowTolerance_m);
  EXPECT_LT(r.max_abs(r.h_err, 30.0 + kDetectDelay_s, 40.0), kLowTolerance_m);
  // No spike: between two 50 Hz records the height in W moves by far less than the 0.8 m
  // step (it moves by the filter's normal correction, a few mm).
  constexpr double kMaxJumpPerRecord_m = 0.01;
  for (std::size_t i = 1; i < r.t.size(); ++i) {
    if (r.t[i] < 2.0) continue;  // start-up transient of the filter
    EXPECT_LT(std::abs(r.z_err[i] - r.z_err[i - 1]), kMaxJumpPerRecord_m) << r.t[i];
  }
  // During the delay it lags by at most the step itself (no overshoot).
  EXPECT_LT(r.max_abs(r.h_err, 10.0, 10.0 + kDetectDelay_s), kPlatformTop_m + kLowTolerance_m);
  EXPECT_EQ(r.us_outcomes.at(AltitudeFusion::Outcome::kSurfaceStep), 2);
}

TEST(FusionAltitude, DescentOntoPlatformBeatsSingleSensors) {
  // 10 s hover at 10 m, then a smooth (cosine) descent to touchdown height over 40 s, all
  // above the platform; the filter starts believing the ground (not the platform) is below.
  constexpr double kTouchdownZ_m = kPlatformTop_m + 0.25;  // legs ~0.25 m below B
  Flight f;
  f.duration_s = 55.0;
  f.z = [](double t) {
    if (t < 10.0) return 10.0;
    if (t > 50.0) return kTouchdownZ_m;
    return kTouchdownZ_m + (10.0 - kTouchdownZ_m) * 0.5 * (1 + std::cos(M_PI * (t - 10.0) / 40.0));
  };
  f.x = [](double) { return 0.0; };
  f.surface = [](double) { return kPlatformTop_m; };
  f.init_z_m = 10.0;
  f.init_surface_m = 0.0;
  const Result r = fly(f);
  std::cout << r.metrics.json().dump() << "\n";
  const auto fused_low = r.metrics.stats("fused", AltitudeBand::kBelow3m);
  const auto fused_high = r.metrics.stats("fused", AltitudeBand::kAbove3m);
  ASSERT_GT(fused_low.n, 100u);
  // Issue targets: fused RMSE <= 0.02 m below 3 m, <= 0.05 m overall.
  constexpr double kBelow3mRmse_m = 0.02;
  constexpr double kOverallRmse_m = 0.05;
  EXPECT_LT(fused_low.rmse_m(), kBelow3mRmse_m);
  EXPECT_LT(r.metrics.stats("fused", AltitudeBand::kAll).rmse_m(), kOverallRmse_m);
  // Better than baro, GPS and vision in both bands.
  for (const char* s : {"baro", "gps", "vision"}) {
    EXPECT_LT(fused_high.rmse_m(), r.metrics.stats(s, AltitudeBand::kAbove3m).rmse_m()) << s;
    EXPECT_LT(fused_low.rmse_m(), r.metrics.stats(s, AltitudeBand::kBelow3m).rmse_m()) << s;
  }
}

}  // namespace
}  // namespace lander::sim
