// Sensor models: each sensor's noise statistics against its params over long samples.
#include "lander/sim/sensors/sensors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "lander/estimator/altitude_fusion.h"

namespace lander::sim {
namespace {

// Mean and std of a sample.
struct Moments {
  double mean{0}, std{0};
};
Moments moments(const std::vector<double>& x) {
  double s = 0, ss = 0;
  for (double v : x) s += v;
  const double m = s / x.size();
  for (double v : x) ss += (v - m) * (v - m);
  return {m, std::sqrt(ss / x.size())};
}
// Normalised autocorrelation at `lag` samples.
double autocorr(const std::vector<double>& x, int lag) {
  const Moments m = moments(x);
  double c = 0;
  for (std::size_t i = 0; i + lag < x.size(); ++i) c += (x[i] - m.mean) * (x[i + lag] - m.mean);
  return c / ((x.size() - lag) * m.std * m.std);
}

// With N independent Gaussian samples the sample std has relative std 1/sqrt(2N) and the
// mean has std sigma/sqrt(N). Tolerances below are 5x those (false-alarm odds ~1e-6); the
// seeds are fixed, so the tests are deterministic anyway.
constexpr double kSigmas = 5.0;

VehicleTruth at_rest(double t, double z = 10.0) {
  VehicleTruth tr;
  tr.t_s = t;
  tr.X_WB.translation() = Eigen::Vector3d(1.0, 2.0, z);
  tr.h_surface_m = z;
  tr.range_m = z;
  return tr;
}

// ------------------------------------------------------------------- config, three tests
template <class P>
void expect_round_trip(P p) {
  P q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
}
template <class P>
void expect_bad_value_named(const std::string& yaml, const std::string& field) {
  P p;
  try {
    read_params(YAML::Load(yaml), "s.yaml", p);
    FAIL() << "expected ConfigError for " << yaml;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(SensorParams, DefaultsAreValid) {
  EXPECT_NO_THROW(ImuParams{}.validate());
  EXPECT_NO_THROW(BaroParams{}.validate());
  EXPECT_NO_THROW(GpsParams{}.validate());
  EXPECT_NO_THROW(UltrasonicParams{}.validate());
  EXPECT_NO_THROW(SensorSuiteParams{}.validate());
}

TEST(SensorParams, SaveLoadRoundTrip) {
  SensorSuiteParams p;
  p.imu.latency_s = 0.004;
  p.baro.bias_mean_m = 1.5;
  p.gps.rate_hz = 10.0;
  p.ultrasonic.glitch_prob = 0.01;
  expect_round_trip(p);
  SensorSuiteParams q;
  read_params(params_to_yaml(p), "<saved>", q);
  EXPECT_EQ(q.imu.latency_s, 0.004);
  EXPECT_EQ(q.gps.rate_hz, 10.0);
}

TEST(SensorParams, BadValueNamesField) {
  expect_bad_value_named<ImuParams>("gyro_noise_std_radps: -1", "gyro_noise_std_radps");
  expect_bad_value_named<BaroParams>("downwash_decay_m: 0", "downwash_decay_m");
  expect_bad_value_named<GpsParams>("rate_hz: 0", "rate_hz");
  expect_bad_value_named<UltrasonicParams>("max_range_m: 0.1", "max_range_m");
  // A nested struct's key is named by its full dotted path, at its line.
  expect_bad_value_named<SensorSuiteParams>("gps: {correlation_time_s: 0}",
                                            "s.yaml:1: invalid value for 'gps.correlation_time_s'");
}

TEST(SensorParams, DefaultYamlFileMatchesDefaults) {
  SensorSuiteParams p;
  read_params(load_yaml_file(std::string(LANDER_MODELS_DIR) + "/sensors_default.yaml"),
              "sensors_default.yaml", p);
  EXPECT_EQ(yaml_to_string(params_to_yaml(p)), yaml_to_string(params_to_yaml(SensorSuiteParams{})));
}

TEST(DelayQueue, DeliversAfterLatencyInOrder) {
  DelayQueue<int> q;
  q.push(1, 0.10);
  q.push(2, 0.15);
  EXPECT_TRUE(q.pop_ready(0.09).empty());
  EXPECT_EQ(q.pop_ready(0.12), std::vector<int>({1}));
  EXPECT_EQ(q.pop_ready(0.20), std::vector<int>({2}));
  EXPECT_TRUE(q.empty());
}

TEST(RateClock, SamplesAtRateFromTheLoop) {
  ImuParams p;  // 250 Hz
  ImuModel imu(p, 1);
  int n = 0;
  for (int i = 0; i < 1000; ++i) {  // 1 s of a 1 kHz loop
    const double t = i * 1e-3;
    if (imu.due(t)) {
      imu.sample(at_rest(t));
      ++n;
    }
  }
  EXPECT_EQ(n, 250);
}

// ---------------------------------------------------------------------------------- IMU
TEST(Imu, WhiteNoiseAndTurnOnBiasAtRest) {
  ImuParams p;
  p.gyro_bias_rw_radps_per_sqrts = 0.0;
  p.accel_bias_rw_mps2_per_sqrts = 0.0;
  ImuModel imu(p, 123);
  const int n = 100000;
  std::vector<double> gx(n), az(n);
  for (int i = 0; i < n; ++i) {
    const ImuSample s = imu.sample(at_rest(i / p.rate_hz));
    gx[i] = s.gyro_B_radps.x();
    az[i] = s.accel_B_mps2.z();
  }
  const Moments mg = moments(gx), ma = moments(az);
  EXPECT_NEAR(mg.mean, imu.gyro_bias_B().x(), kSigmas * p.gyro_noise_std_radps / std::sqrt(n));
  EXPECT_NEAR(mg.std, p.gyro_noise_std_radps, kSigmas * p.gyro_noise_std_radps / std::sqrt(2.0 * n));
  // Level at rest: specific force +g along z_B.
  EXPECT_NEAR(ma.mean, p.gravity_mps2 + imu.accel_bias_B().z(),
              kSigmas * p.accel_noise_std_mps2 / std::sqrt(n));
  EXPECT_NEAR(ma.std, p.accel_noise_std_mps2,
              kSigmas * p.accel_noise_std_mps2 / std::sqrt(2.0 * n));
  // White: no correlation between successive samples (std of the estimate 1/sqrt(n)).
  EXPECT_NEAR(autocorr(gx, 1), 0.0, kSigmas / std::sqrt(n));
}

TEST(Imu, TurnOnBiasSpreadAcrossSeeds) {
  ImuParams p;
  const int n = 4000;
  std::vector<double> bg(n);
  for (int i = 0; i < n; ++i) bg[i] = ImuModel(p, 1000 + i).gyro_bias_B().y();
  EXPECT_NEAR(moments(bg).std, p.gyro_bias_init_std_radps,
              kSigmas * p.gyro_bias_init_std_radps / std::sqrt(2.0 * n));
}

TEST(Imu, BiasRandomWalkGrowsAsSqrtTime) {
  ImuParams p;
  p.gyro_bias_rw_radps_per_sqrts = 1e-3;
  ImuModel imu(p, 5);
  // Increments of the bias over 1 s windows: std = rw * sqrt(1 s).
  std::vector<double> inc;
  double last = imu.gyro_bias_B().z();
  for (int i = 1; i <= 250 * 4000; ++i) {
    imu.sample(at_rest(i / p.rate_hz));
    if (i % 250 == 0) {
      inc.push_back(imu.gyro_bias_B().z() - last);
      last = imu.gyro_bias_B().z();
    }
  }
  EXPECT_NEAR(moments(inc).std, 1e-3, kSigmas * 1e-3 / std::sqrt(2.0 * inc.size()));
}

TEST(Imu, SpecificForceRotatesIntoBody) {
  ImuParams p;
  p.gyro_noise_std_radps = p.accel_noise_std_mps2 = 0;
  p.gyro_bias_init_std_radps = p.accel_bias_init_std_mps2 = 0;
  p.gyro_bias_rw_radps_per_sqrts = p.accel_bias_rw_mps2_per_sqrts = 0;
  ImuModel imu(p, 1);
  VehicleTruth tr = at_rest(0.0);
  tr.X_WB.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  tr.a_W_mps2 = {1.0, 0.0, 2.0};
  tr.omega_B_radps = {0.1, -0.2, 0.3};
  const ImuSample s = imu.sample(tr);
  const Eigen::Vector3d f_expected =
      tr.X_WB.linear().transpose() * Eigen::Vector3d(1.0, 0.0, 2.0 + p.gravity_mps2);
  EXPECT_NEAR((s.accel_B_mps2 - f_expected).norm(), 0.0, 1e-12);
  EXPECT_NEAR((s.gyro_B_radps - tr.omega_B_radps).norm(), 0.0, 1e-12);
}

// ------------------------------------------------------------------------------ Barometer
TEST(Isa, Eq8MatchesStandardAtmosphereAndInverts) {
  EXPECT_NEAR(isa_pressure_pa(0.0), 101325.0, 1e-9);
  // ISA table (ICAO Doc 7488): 1000 m -> 89874.6 Pa, 5000 m -> 54019.9 Pa.
  constexpr double kTableTolerance_Pa = 2.0;  // table rounding and r/g_n digits
  EXPECT_NEAR(isa_pressure_pa(1000.0), 89874.6, kTableTolerance_Pa);
  EXPECT_NEAR(isa_pressure_pa(5000.0), 54019.9, kTableTolerance_Pa);
  for (double h : {-100.0, 0.0, 12.3, 500.0, 3000.0}) {
    EXPECT_NEAR(isa_altitude_m(isa_pressure_pa(h)), h, 1e-6) << h;
  }
}

BaroParams quiet_baro() {
  BaroParams p;
  p.drift_rw_m_per_sqrts = 0.0;
  return p;
}

TEST(Baro, ConstantBiasPlusWhiteNoiseEq9) {
  BaroParams p = quiet_baro();
  p.origin_msl_m = 200.0;
  BaroModel baro(p, 99);
  const int n = 50000;
  std::vector<double> err(n);
  for (int i = 0; i < n; ++i) {
    const VehicleTruth tr = at_rest(i / p.rate_hz, 20.0);
    err[i] = isa_altitude_m(baro.sample(tr).pressure_pa) - p.origin_msl_m - 20.0;
    EXPECT_NEAR(err[i], baro.last_error_m(), 1e-6);
  }
  const Moments m = moments(err);
  // 20 m above the surface the downwash term is exp(-20) of its size: negligible.
  EXPECT_NEAR(m.mean, baro.bias_m(), kSigmas * p.noise_std_m / std::sqrt(n));
  EXPECT_NEAR(m.std, p.noise_std_m, kSigmas * p.noise_std_m / std::sqrt(2.0 * n));
  EXPECT_NEAR(autocorr(err, 1), 0.0, kSigmas / std::sqrt(n));
}

TEST(Baro, BiasIsRandomConstantAcrossRuns) {
  BaroParams p;
  p.bias_mean_m = 0.5;
  const int n = 4000;
  std::vector<double> b(n);
  for (int i = 0; i < n; ++i) b[i] = BaroModel(p, 7000 + i).bias_m();
  const Moments m = moments(b);
  EXPECT_NEAR(m.mean, 0.5, kSigmas * p.bias_std_m / std::sqrt(n));
  EXPECT_NEAR(m.std, p.bias_std_m, kSigmas * p.bias_std_m / std::sqrt(2.0 * n));
}

TEST(Baro, DriftIsRandomWalk) {
  BaroParams p;
  p.noise_std_m = 0.0;
  p.drift_rw_m_per_sqrts = 0.01;
  BaroModel baro(p, 3);
  std::vector<double> inc;
  double last = 0.0;
  for (int i = 1; i <= 50 * 10000; ++i) {
    baro.sample(at_rest(i / p.rate_hz, 20.0));
    if (i % 50 == 0) {  // 1 s windows
      inc.push_back(baro.drift_m() - last);
      last = baro.drift_m();
    }
  }
  EXPECT_NEAR(moments(inc).std, 0.01, kSigmas * 0.01 / std::sqrt(2.0 * inc.size()));
}

TEST(Baro, DownwashErrorGrowsNearTheSurface) {
  BaroParams p = quiet_baro();
  BaroModel baro(p, 11);
  auto mean_err = [&](double h, double thrust) {
    double s = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      VehicleTruth tr = at_rest(i / p.rate_hz, h);
      tr.thrust_fraction = thrust;
      baro.sample(tr);
      s += baro.last_error_m() - baro.bias_m();
    }
    return s / n;
  };
  const double tol = kSigmas * p.noise_std_m / std::sqrt(20000.0);
  EXPECT_NEAR(mean_err(10.0, 0.5), p.downwash_error_m * std::exp(-10.0), tol);
  EXPECT_NEAR(mean_err(0.3, 0.5), p.downwash_error_m * std::exp(-0.3), tol);
  // Motors off on the ground: no downwash.
  EXPECT_NEAR(mean_err(0.3, 0.0), 0.0, tol);
  EXPECT_LT(p.downwash_error_m * std::exp(-0.3), -0.3);  // i.e. a real, large effect
}

// ------------------------------------------------------------------------------------ GPS
TEST(Gps, CorrelatedErrorStdAndCorrelationTime) {
  GpsParams p;
  p.velocity_std_mps = 0.1;
  GpsModel gps(p, 2024);
  const int n = 200000;  // 40000 s at 5 Hz = 4000 correlation times
  std::vector<double> ex(n), ez(n), evx(n);
  for (int i = 0; i < n; ++i) {
    const VehicleTruth tr = at_rest(i / p.rate_hz);
    const GpsSample s = gps.sample(tr);
    ASSERT_TRUE(s.valid);
    ex[i] = s.p_W_m.x() - 1.0;
    ez[i] = s.p_W_m.z() - 10.0;
    evx[i] = s.v_W_mps.x();
  }
  // Effective independent samples ~ T / (2 tau) = 2000: std of the std ~ 1.6 %.
  const double n_eff = n / p.rate_hz / (2.0 * p.correlation_time_s);
  EXPECT_NEAR(moments(ex).std, p.horizontal_std_m,
              kSigmas * p.horizontal_std_m / std::sqrt(2.0 * n_eff));
  EXPECT_NEAR(moments(ez).std, p.vertical_std_m, kSigmas * p.vertical_std_m / std::sqrt(2.0 * n_eff));
  EXPECT_NEAR(moments(ex).mean, 0.0, kSigmas * p.horizontal_std_m / std::sqrt(n_eff));
  EXPECT_GT(p.vertical_std_m, p.horizontal_std_m);  // worse vertical, as real receivers
  // Correlation at lag tau: e^-1 (estimator std ~ 1/sqrt(n_eff)).
  const int lag = static_cast<int>(p.correlation_time_s * p.rate_hz);
  EXPECT_NEAR(autocorr(ex, lag), std::exp(-1.0), kSigmas / std::sqrt(n_eff));
  // Velocity noise is white.
  EXPECT_NEAR(moments(evx).std, p.velocity_std_mps, kSigmas * p.velocity_std_mps / std::sqrt(2.0 * n));
  EXPECT_NEAR(autocorr(evx, 1), 0.0, kSigmas / std::sqrt(n));
}

TEST(Gps, DropoutsAndGlitchesAtTheirRates) {
  GpsParams p;
  p.dropout_rate_per_s = 0.01;
  p.dropout_duration_s = 3.0;
  p.glitch_rate_per_s = 0.01;
  p.glitch_duration_s = 2.0;
  p.glitch_std_m = 20.0;  // far above the normal error, so glitches are recognisable
  GpsModel gps(p, 77);
  const int n = 500000;  // 100000 s: ~1000 events of each kind
  int invalid = 0, glitched = 0, valid = 0;
  for (int i = 0; i < n; ++i) {
    const GpsSample s = gps.sample(at_rest(i / p.rate_hz));
    if (!s.valid) {
      ++invalid;
      continue;
    }
    ++valid;
    if ((s.p_W_m - Eigen::Vector3d(1, 2, 10) - gps.correlated_error_W_m()).norm() > 1e-9) {
      ++glitched;
    }
  }
  // Renewal process: fraction = rate dur / (1 + rate dur); ~1000 events -> ~3 % rel. std.
  constexpr double kRateRelTolerance = 0.15;
  const double f_drop = 0.03 / 1.03, f_glitch = 0.02 / 1.02;
  EXPECT_NEAR(invalid / double(n), f_drop, kRateRelTolerance * f_drop);
  EXPECT_NEAR(glitched / double(valid), f_glitch, kRateRelTolerance * f_glitch);
}

TEST(Gps, InjectedOffsetAppliesOnlyInItsWindow) {
  GpsParams p;
  GpsModel a(p, 5), b(p, 5);
  b.inject_offset(10.0, 2.0, {0, 0, 5.0});
  for (int i = 0; i < 100; ++i) {
    const double t = i / p.rate_hz;
    const double dz = b.sample(at_rest(t)).p_W_m.z() - a.sample(at_rest(t)).p_W_m.z();
    EXPECT_NEAR(dz, (t >= 10.0 && t < 12.0) ? 5.0 : 0.0, 1e-9) << t;
  }
}

// ----------------------------------------------------------------------------- Ultrasonic
TEST(Ultrasonic, InRangeAccuracyAbout3mm) {
  UltrasonicParams p;
  UltrasonicModel us(p, 8);
  const int n = 50000;
  std::vector<double> err(n);
  for (int i = 0; i < n; ++i) {
    const double r = 0.2 + 2.8 * (i % 100) / 100.0;  // sweep the valid range
    VehicleTruth tr = at_rest(i / p.rate_hz, r);
    err[i] = us.sample(tr).range_m - r;
    ASSERT_FALSE(us.last_was_garbage());
  }
  const Moments m = moments(err);
  EXPECT_NEAR(m.mean, 0.0, kSigmas * p.noise_std_m / std::sqrt(n));
  EXPECT_NEAR(m.std, p.noise_std_m, kSigmas * p.noise_std_m / std::sqrt(2.0 * n));
}

TEST(Ultrasonic, UnboundedGarbageOutsideTheRangeEq12) {
  UltrasonicParams p;
  UltrasonicModel us(p, 9);
  for (double r : {0.10, 3.2, 10.0, std::numeric_limits<double>::infinity()}) {
    const int n = 20000;
    std::vector<double> v(n);
    int near_truth = 0;
    for (int i = 0; i < n; ++i) {
      VehicleTruth tr = at_rest(i / p.rate_hz, 10.0);
      tr.range_m = r;
      v[i] = us.sample(tr).range_m;
      EXPECT_TRUE(us.last_was_garbage());
      EXPECT_GE(v[i], 0.0);
      if (std::abs(v[i] - r) < 0.05) ++near_truth;
    }
    // |Cauchy(0, s)| has median s; its sample median has relative std ~ 1.6/sqrt(n) ~ 1 %.
    std::nth_element(v.begin(), v.begin() + n / 2, v.end());
    EXPECT_NEAR(v[n / 2], p.garbage_scale_m, 0.05 * p.garbage_scale_m) << r;
    // Unbounded: far beyond the sensor's range in a long sample (P(> 100 s) = 0.6 %).
    EXPECT_GT(*std::max_element(v.begin(), v.end()), 20.0 * p.max_range_m);
    // Not the truth: only chance hits within 5 cm. The |Cauchy(0, s)| density is at most
    // 2 / (pi s), so P(hit) <= 0.1 m * 2 / (pi s) = 1.27 % (for s = 5 m), plus 5 binomial std.
    const double p_chance = 0.1 * 2.0 / (M_PI * p.garbage_scale_m);
    EXPECT_LT(near_truth, n * p_chance + kSigmas * std::sqrt(n * p_chance)) << r;
  }
}

TEST(Ultrasonic, GlitchProbabilityAndInjectedBursts) {
  UltrasonicParams p;
  p.glitch_prob = 0.05;
  UltrasonicModel us(p, 10);
  us.inject_garbage(100.0, 10.0);
  int glitches = 0, n = 0;
  for (int i = 0; i < 100000; ++i) {
    const double t = 1000.0 + i / p.rate_hz;
    us.sample(at_rest(t, 1.5));
    glitches += us.last_was_garbage();
    ++n;
  }
  // Binomial: std = sqrt(p (1-p) / n) = 0.07 %.
  EXPECT_NEAR(glitches / double(n), 0.05, kSigmas * std::sqrt(0.05 * 0.95 / n));
  UltrasonicParams q;
  UltrasonicModel burst(q, 11);
  burst.inject_garbage(1.0, 0.5);
  for (int i = 0; i < 40; ++i) {
    const double t = i / q.rate_hz;
    burst.sample(at_rest(t, 1.5));
    EXPECT_EQ(burst.last_was_garbage(), t >= 1.0 && t < 1.5) << t;
  }
}

TEST(Sensors, SameSeedSameSamples) {
  GpsModel a(GpsParams{}, 3), b(GpsParams{}, 3);
  BaroModel c(BaroParams{}, 3), d(BaroParams{}, 3);
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(a.sample(at_rest(i * 0.2)).p_W_m, b.sample(at_rest(i * 0.2)).p_W_m);
    EXPECT_EQ(c.sample(at_rest(i * 0.02)).pressure_pa, d.sample(at_rest(i * 0.02)).pressure_pa);
  }
}

TEST(SensorSuite, RatesLatenciesAndSeeds) {
  SensorSuiteParams p;
  SensorSuite a(p, 42), b(p, 42), c(p, 43);
  int n_imu = 0, n_baro = 0, n_gps = 0, n_us = 0;
  bool differs = false;
  for (int k = 0; k <= 2000; ++k) {  // 2 s of a 1 kHz loop
    const double t = k * 1e-3;
    const VehicleTruth tr = at_rest(t, 2.0);
    a.transmit(a.sample(tr));
    b.transmit(b.sample(tr));
    c.transmit(c.sample(tr));
    const auto da = a.deliver(t), db = b.deliver(t), dc = c.deliver(t);
    for (const auto& s : da.baro) EXPECT_NEAR(t - s.t_s, p.baro.latency_s, 1e-3 + 1e-9);
    for (const auto& s : da.gps) EXPECT_NEAR(t - s.t_s, p.gps.latency_s, 1e-3 + 1e-9);
    for (std::size_t i = 0; i < da.gps.size(); ++i) EXPECT_EQ(da.gps[i].p_W_m, db.gps[i].p_W_m);
    for (std::size_t i = 0; i < da.gps.size() && i < dc.gps.size(); ++i) {
      differs = differs || da.gps[i].p_W_m != dc.gps[i].p_W_m;
    }
    n_imu += da.imu.size();
    n_baro += da.baro.size();
    n_gps += da.gps.size();
    n_us += da.ultrasonic.size();
  }
  EXPECT_TRUE(differs);
  // Samples taken in [0, 2] s and delivered by 2 s: rate * (2 - latency) (+1 for t = 0).
  EXPECT_EQ(n_imu, 501);
  EXPECT_EQ(n_baro, static_cast<int>(std::floor(50 * (2.0 - 0.02) + 1e-9)) + 1);
  EXPECT_EQ(n_gps, static_cast<int>(std::floor(5 * (2.0 - 0.1) + 1e-9)) + 1);
  EXPECT_EQ(n_us, static_cast<int>(std::floor(20 * (2.0 - 0.01) + 1e-9)) + 1);
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(1, "gps"));
  EXPECT_NE(derive_seed(1, "imu"), derive_seed(2, "imu"));
  EXPECT_EQ(derive_seed(7, "baro"), derive_seed(7, "baro"));
}

// The platform's broadcast (sensors.platform_telemetry): off by default, so nothing is sampled
// even with the platform's truth at hand; on, the platform's GNSS fix (its error statistics,
// not the truth) arrives after its latency at its rate less the lost messages, and turning
// it on leaves every vehicle sensor's samples as they were (its own random streams).
TEST(PlatformTelemetry, OffByDefaultOnItsRateLatencyLossAndErrors) {
  PlatformTruth plat;
  plat.p_W_m = Eigen::Vector3d(30.0, -4.0, 0.8);
  plat.v_W_mps = Eigen::Vector3d(1.0, 0.5, 0.0);
  SensorSuiteParams off;
  SensorSuite s_off(off, 5);
  SensorSuiteParams on = off;
  on.platform_telemetry.enabled = true;
  on.platform_telemetry.message_loss_prob = 0.2;
  on.platform_telemetry.gnss.correlation_time_s = 0.05;  // ~independent errors at 5 Hz
  on.platform_telemetry.gnss.horizontal_std_m = 1.5;
  SensorSuite s_on(on, 5);
  const double T = 2000.0;  // 10000 fixes at 5 Hz
  std::vector<double> ex, ey, evx;
  long delivered = 0;
  for (int k = 0; k <= static_cast<int>(T * 100); ++k) {  // a 100 Hz loop is enough here
    const double t = k * 1e-2;
    const VehicleTruth tr = at_rest(t, 2.0);
    const PlatformTruth now{t, plat.p_W_m + plat.v_W_mps * t, plat.v_W_mps};
    const SensorSuite::Sampled a = s_off.sample(tr, &now), b = s_on.sample(tr, &now);
    EXPECT_FALSE(a.platform_telemetry.has_value());
    // The vehicle's own sensors draw the same samples either way.
    ASSERT_EQ(a.gps.has_value(), b.gps.has_value());
    ASSERT_EQ(a.imu.has_value(), b.imu.has_value());
    if (a.gps) {
      EXPECT_EQ(a.gps->p_W_m, b.gps->p_W_m);
    }
    if (a.imu) {
      EXPECT_EQ(a.imu->accel_B_mps2, b.imu->accel_B_mps2);
    }
    s_on.transmit(b);
    for (const GpsSample& g : s_on.deliver(t).platform_telemetry) {
      ++delivered;
      EXPECT_NEAR(t - g.t_s, on.platform_telemetry.gnss.latency_s, 1e-2 + 1e-9);
      const Eigen::Vector3d truth = plat.p_W_m + plat.v_W_mps * g.t_s;
      ex.push_back(g.p_W_m.x() - truth.x());
      ey.push_back(g.p_W_m.y() - truth.y());
      evx.push_back(g.v_W_mps.x() - plat.v_W_mps.x());
    }
  }
  // Messages: 5 Hz over T less the latency, each kept with probability 0.8 (binomial).
  const double n = 5.0 * (T - on.platform_telemetry.gnss.latency_s);
  const double kept = 1.0 - on.platform_telemetry.message_loss_prob;
  EXPECT_NEAR(delivered, n * kept, kSigmas * std::sqrt(n * kept * (1 - kept)));
  EXPECT_NEAR(s_on.platform_telemetry().lost(), n * (1 - kept), kSigmas * std::sqrt(n * kept * (1 - kept)) + 2);
  const double N = static_cast<double>(ex.size());
  for (const std::vector<double>* e : {&ex, &ey}) {
    const Moments m = moments(*e);
    EXPECT_NEAR(m.mean, 0.0, kSigmas * 1.5 / std::sqrt(N));
    EXPECT_NEAR(m.std, 1.5, kSigmas * 1.5 / std::sqrt(2 * N));
  }
  EXPECT_NEAR(moments(evx).std, on.platform_telemetry.gnss.velocity_std_mps,
              kSigmas * on.platform_telemetry.gnss.velocity_std_mps / std::sqrt(2 * N));
}

TEST(PlatformTelemetry, BadValuesNameTheirKey) {
  expect_bad_value_named<SensorSuiteParams>("platform_telemetry: {message_loss_prob: 1.5}",
                                            "platform_telemetry.message_loss_prob");
  expect_bad_value_named<SensorSuiteParams>("platform_telemetry: {gnss: {rate_hz: 0}}",
                                            "platform_telemetry.gnss.rate_hz");
}

}  // namespace
}  // namespace lander::sim
