#include "lander/sim/sensors/sensors.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "lander/estimator/altitude_fusion.h"
#include "lander/core/types.h"

namespace lander::sim {

namespace {
// Seconds since the previous sample (0 for the first one), for random walks.
double since(double& last_t_s, double t_s) {
  const double dt = last_t_s < 0 ? 0.0 : std::max(0.0, t_s - last_t_s);
  last_t_s = t_s;
  return dt;
}
}  // namespace

void SensorSuiteParams::validate() const {
  validate_nested("imu", imu);
  validate_nested("baro", baro);
  validate_nested("gps", gps);
  validate_nested("ultrasonic", ultrasonic);
  validate_nested("magnetometer", magnetometer);
  validate_nested("platform_telemetry", platform_telemetry);
}

void PlatformTelemetryParams::validate() const {
  check_fields(*this);
  validate_nested("gnss", gnss);
}

// ---------------------------------------------------------------------------------- IMU
ImuModel::ImuModel(const ImuParams& p, std::uint64_t seed)
    : p_(p), rng_(seed), clock_((p.validate(), p.rate_hz)) {
  for (int i = 0; i < 3; ++i) b_g_[i] = p_.gyro_bias_init_std_radps * n_(rng_);
  for (int i = 0; i < 3; ++i) b_a_[i] = p_.accel_bias_init_std_mps2 * n_(rng_);
}

ImuSample ImuModel::sample(const VehicleTruth& truth) {
  clock_.advance(truth.t_s);
  // Bias random walk over the time since the last sample.
  const double sq = std::sqrt(since(last_t_s_, truth.t_s));
  for (int i = 0; i < 3; ++i) b_g_[i] += p_.gyro_bias_rw_radps_per_sqrts * sq * n_(rng_);
  for (int i = 0; i < 3; ++i) b_a_[i] += p_.accel_bias_rw_mps2_per_sqrts * sq * n_(rng_);
  ImuSample s;
  s.t_s = truth.t_s;
  // Specific force: f_B = R_WB^T (a_W - g_W), g_W = (0, 0, -g).
  const Eigen::Matrix3d R_WB = truth.X_WB.linear();
  const Eigen::Vector3d f_B =
      R_WB.transpose() * (truth.a_W_mps2 + Eigen::Vector3d(0, 0, p_.gravity_mps2));
  // A misaligned IMU measures in its own axes S: R_SB = R_BS^T.
  const Eigen::Matrix3d R_SB = R_from_rpy(p_.misalignment_rad).transpose();
  const Eigen::Vector3d w_S = R_SB * truth.omega_B_radps, f_S = R_SB * f_B;
  for (int i = 0; i < 3; ++i) {
    s.gyro_B_radps[i] = w_S[i] + b_g_[i] + p_.gyro_noise_std_radps * n_(rng_);
    s.accel_B_mps2[i] = f_S[i] + b_a_[i] + p_.accel_noise_std_mps2 * n_(rng_);
  }
  return s;
}

// ------------------------------------------------------------------------------ Barometer
BaroModel::BaroModel(const BaroParams& p, std::uint64_t seed)
    : p_(p), rng_(seed), clock_((p.validate(), p.rate_hz)) {
  // eps_b: a random constant per run (seed 004 eq. 9).
  bias_m_ = p_.bias_mean_m + p_.bias_std_m * n_(rng_);
}

double BaroModel::downwash_error_m(double h_surface_m, double thrust_fraction) const {
  if (!std::isfinite(h_surface_m)) return 0.0;
  const double h = std::max(0.0, h_surface_m);
  const double load = std::max(0.0, thrust_fraction) / p_.hover_thrust_fraction;
  return p_.downwash_error_m * load * std::exp(-h / p_.downwash_decay_m);
}

BaroSample BaroModel::sample(const VehicleTruth& truth) {
  clock_.advance(truth.t_s);
  const double dt = since(last_t_s_, truth.t_s);
  drift_m_ += p_.drift_rw_m_per_sqrts * std::sqrt(dt) * n_(rng_);
  // h_q = h_0 + eps_b + w_q (eq. 9) + drift + downwash error.
  last_error_m_ = bias_m_ + drift_m_ + downwash_error_m(truth.h_surface_m, truth.thrust_fraction) +
                  p_.noise_std_m * n_(rng_);
  const double h_msl = p_.origin_msl_m + truth.X_WB.translation().z() + last_error_m_;
  BaroSample s;
  s.t_s = truth.t_s;
  s.pressure_pa = isa_pressure_pa(h_msl);  // eq. 8, inverted
  return s;
}

// ------------------------------------------------------------------------------------ GPS
GpsModel::GpsModel(const GpsParams& p, std::uint64_t seed)
    : p_(p), rng_(seed), clock_((p.validate(), p.rate_hz)) {
  sigma_W_ = {p_.horizontal_std_m, p_.horizontal_std_m, p_.vertical_std_m};
  for (int i = 0; i < 3; ++i) err_W_[i] = sigma_W_[i] * n_(rng_);
}

void GpsModel::inject_offset(double t_start_s, double duration_s,
                             const Eigen::Vector3d& offset_W_m) {
  if (!(duration_s >= 0)) throw std::invalid_argument("GpsModel::inject_offset: duration < 0");
  offsets_.push_back({t_start_s, t_start_s + duration_s, offset_W_m});
}

GpsSample GpsModel::sample(const VehicleTruth& truth) {
  clock_.advance(truth.t_s);
  const double t = truth.t_s;
  const double dt = since(last_t_s_, t);
  // Gauss-Markov position error, exact discretisation (stationary std sigma).
  const double a = std::exp(-dt / p_.correlation_time_s);
  const double b = std::sqrt(1.0 - a * a);
  for (int i = 0; i < 3; ++i) err_W_[i] = a * err_W_[i] + b * sigma_W_[i] * n_(rng_);
  // Poisson-triggered glitches and drop-outs (probability rate * dt per sample).
  if (t >= glitch_until_s_ && u_(rng_) < p_.glitch_rate_per_s * dt) {
    glitch_until_s_ = t + p_.glitch_duration_s;
    for (int i = 0; i < 3; ++i) glitch_W_[i] = p_.glitch_std_m * n_(rng_);
  }
  if (t >= dropout_until_s_ && u_(rng_) < p_.dropout_rate_per_s * dt) {
    dropout_until_s_ = t + p_.dropout_duration_s;
  }
  GpsSample s;
  s.t_s = t;
  s.valid = t >= dropout_until_s_;
  s.p_W_m = truth.X_WB.translation() + err_W_;
  if (t < glitch_until_s_) s.p_W_m += glitch_W_;
  for (const Offset& o : offsets_) {
    if (t >= o.t0 && t < o.t1) s.p_W_m += o.d;
  }
  for (int i = 0; i < 3; ++i) s.v_W_mps[i] = truth.v_W_mps[i] + p_.velocity_std_mps * n_(rng_);
  if (!s.valid) {
    s.p_W_m.setZero();
    s.v_W_mps.setZero();
  }
  return s;
}

// --------------------------------------------------------------------- platform telemetry
PlatformTelemetryModel::PlatformTelemetryModel(const PlatformTelemetryParams& p, std::uint64_t seed)
    : p_((p.validate(), p)), gnss_(p.gnss, derive_seed(seed, "gnss")), link_rng_(derive_seed(seed, "link")) {}

std::optional<GpsSample> PlatformTelemetryModel::sample(const PlatformTruth& platform) {
  VehicleTruth t;  // the receiver rides on the platform
  t.t_s = platform.t_s;
  t.X_WB.translation() = platform.p_W_m;
  t.v_W_mps = platform.v_W_mps;
  GpsSample g = gnss_.sample(t);
  if (u_(link_rng_) < p_.message_loss_prob) {
    ++lost_;
    return std::nullopt;
  }
  return g;
}

// ----------------------------------------------------------------------------- Ultrasonic
UltrasonicModel::UltrasonicModel(const UltrasonicParams& p, std::uint64_t seed)
    : p_(p), rng_(seed), clock_((p.validate(), p.rate_hz)) {}

void UltrasonicModel::inject_garbage(double t_start_s, double duration_s) {
  if (!(duration_s >= 0)) {
    throw std::invalid_argument("UltrasonicModel::inject_garbage: duration < 0");
  }
  bursts_.push_back({t_start_s, t_start_s + duration_s});
}

double UltrasonicModel::garbage() {
  // omega_lc of eq. 12: unbounded. |Cauchy| has no finite mean or variance.
  return std::abs(p_.garbage_scale_m * cauchy_(rng_));
}

UltrasonicSample UltrasonicModel::sample(const VehicleTruth& truth) {
  clock_.advance(truth.t_s);
  UltrasonicSample s;
  s.t_s = truth.t_s;
  const double r = truth.range_m;
  const bool in_range = std::isfinite(r) && r >= p_.min_range_m && r <= p_.max_range_m;
  bool burst = false;
  for (const auto& b : bursts_) burst = burst || (truth.t_s >= b.first && truth.t_s < b.second);
  const bool glitch = p_.glitch_prob > 0 && u_(rng_) < p_.glitch_prob;
  last_garbage_ = !in_range || burst || glitch;
  s.range_m = last_garbage_ ? garbage() : r + p_.noise_std_m * n_(rng_);  // eq. 12
  return s;
}

// -------------------------------------------------------------------------- magnetometer
MagnetometerModel::MagnetometerModel(const MagnetometerParams& p, std::uint64_t seed)
    : p_(p), rng_(seed), clock_((p.validate(), p.rate_hz)) {
  for (int i = 0; i < 3; ++i) bias_[i] = p_.bias_std_uT * n_(rng_);
}

MagSample MagnetometerModel::sample(const VehicleTruth& truth) {
  clock_.advance(truth.t_s);
  MagSample s;
  s.t_s = truth.t_s;
  s.field_B_uT = truth.X_WB.linear().transpose() * p_.true_field_W_uT() + bias_;
  for (int i = 0; i < 3; ++i) s.field_B_uT[i] += p_.noise_std_uT * n_(rng_);
  return s;
}

Eigen::Vector3d MagnetometerParams::true_field_W_uT() const {
  return Eigen::AngleAxisd(declination_rad, Eigen::Vector3d::UnitZ()) * field_W_uT;
}

// ------------------------------------------------------------------------------- suite
std::uint64_t derive_seed(std::uint64_t scenario_seed, const std::string& stream) {
  // FNV-1a of the stream name mixed with the scenario seed through SplitMix64's finaliser.
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : stream) h = (h ^ c) * 1099511628211ull;
  std::uint64_t z = scenario_seed + 0x9E3779B97F4A7C15ull * (h | 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

SensorSuite::SensorSuite(const SensorSuiteParams& p, std::uint64_t scenario_seed)
    : p_((p.validate(), p)),
      imu_(p.imu, derive_seed(scenario_seed, "imu")),
      mag_(p.magnetometer, derive_seed(scenario_seed, "magnetometer")),
      baro_(p.baro, derive_seed(scenario_seed, "baro")),
      gps_(p.gps, derive_seed(scenario_seed, "gps")),
      us_(p.ultrasonic, derive_seed(scenario_seed, "ultrasonic")),
      telemetry_(p.platform_telemetry, derive_seed(scenario_seed, "platform_telemetry")) {}

SensorSuite::Sampled SensorSuite::sample(const VehicleTruth& truth, const PlatformTruth* platform) {
  const double t = truth.t_s;
  Sampled s;
  if (imu_.due(t)) s.imu = imu_.sample(truth);
  if (mag_.due(t)) s.magnetometer = mag_.sample(truth);
  if (baro_.due(t)) s.baro = baro_.sample(truth);
  if (gps_.due(t)) s.gps = gps_.sample(truth);
  if (us_.due(t)) s.ultrasonic = us_.sample(truth);
  if (platform != nullptr && telemetry_.due(platform->t_s)) s.platform_telemetry = telemetry_.sample(*platform);
  return s;
}

void SensorSuite::transmit(const Sampled& s) {
  if (s.imu) q_imu_.push(*s.imu, s.imu->t_s + p_.imu.latency_s);
  if (s.magnetometer) q_mag_.push(*s.magnetometer, s.magnetometer->t_s + p_.magnetometer.latency_s);
  if (s.baro) q_baro_.push(*s.baro, s.baro->t_s + p_.baro.latency_s);
  if (s.gps) q_gps_.push(*s.gps, s.gps->t_s + p_.gps.latency_s);
  if (s.ultrasonic) q_us_.push(*s.ultrasonic, s.ultrasonic->t_s + p_.ultrasonic.latency_s);
  if (s.platform_telemetry) {
    q_telemetry_.push(*s.platform_telemetry, s.platform_telemetry->t_s + p_.platform_telemetry.gnss.latency_s);
  }
}

SensorSuite::Delivered SensorSuite::deliver(double t_s) {
  Delivered d;
  d.imu = q_imu_.pop_ready(t_s);
  d.baro = q_baro_.pop_ready(t_s);
  d.gps = q_gps_.pop_ready(t_s);
  d.ultrasonic = q_us_.pop_ready(t_s);
  d.magnetometer = q_mag_.pop_ready(t_s);
  d.platform_telemetry = q_telemetry_.pop_ready(t_s);
  return d;
}

}  // namespace lander::sim
