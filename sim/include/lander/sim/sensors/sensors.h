// Sensor models: IMU, barometer, GPS and ultrasonic rangefinder. Each takes its params and a
// 64-bit seed (one seed per stream, derived by the loop from the scenario seed) and turns
// the truth (truth.h) into the sample types the vehicle delivers (estimator/types.h).
//
// Timing: each model samples at its own rate; the loop asks `due(t)` every physics step and
// calls `sample(truth)` when it is true. Latency: a sample is stamped with its SAMPLING time
// (t_s = truth.t_s) and the loop delivers it `params.latency_s` later; DelayQueue below is the
// small FIFO for that (push at sampling time, pop when sim time reaches t_s + latency).
//
// Error models (all seeded, all reproducible):
//   IMU:   gyro = omega_B + b_g + n_g,   accel = R_WB^T (a_W + g e_z) + b_a + n_a,
//          b_g, b_a: initial N(0, init std) then random walk; n white per sample.
//   Baro:  seed 004 eq. 9, h_q = h_0 + eps_b + w_q, plus a slow random-walk drift and the
//          downwash / ground-effect error near the surface below (seed 004 sec. 3.1, 4.2):
//            e_dw = downwash_error_m * (thrust_fraction / hover_thrust_fraction)
//                   * exp(-h_surface / downwash_decay_m)
//          (negative by default: rotor wash raises the static pressure near the ground, so
//          the baro reads low, as flight stacks that compensate it assume). The erroneous
//          altitude goes through the ISA model (seed 004 eq. 8) to a pressure in Pa.
//   GPS:   seed 004 eq. 10, but with time-correlated (first-order Gauss-Markov) position
//          error, metre-level horizontal and worse vertical, as real receivers; white
//          velocity noise; random glitches (offset steps) and drop-outs (valid = false);
//          and a scripted offset for fault injection.
//   Ultrasonic: seed 004 eq. 12: inside [min_range, max_range] the range plus white noise
//          (~3 mm); outside, an unbounded random value |Cauchy(0, garbage_scale_m)|; with
//          probability glitch_prob a garbage value even inside the range.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "lander/core/params_io.h"
#include "lander/core/types.h"
#include "lander/sim/plant/truth.h"

namespace lander::sim {

// FIFO that delivers samples a fixed latency after their sampling time.
template <class Sample>
class DelayQueue {
 public:
  void push(Sample s, double deliver_at_s) { q_.emplace_back(deliver_at_s, std::move(s)); }
  // Removes and returns (in order) every sample whose delivery time is <= t_s.
  std::vector<Sample> pop_ready(double t_s) {
    std::vector<Sample> out;
    while (!q_.empty() && q_.front().first <= t_s + 1e-12) {
      out.push_back(std::move(q_.front().second));
      q_.pop_front();
    }
    return out;
  }
  bool empty() const { return q_.empty(); }

 private:
  std::deque<std::pair<double, Sample>> q_;
};

// Sampling clock: due every 1/rate_hz seconds starting at t = 0 (no drift).
class RateClock {
 public:
  explicit RateClock(double rate_hz) : period_s_(1.0 / rate_hz) {}
  bool due(double t_s) const { return t_s + 1e-9 >= next_s_; }
  void advance(double t_s) {
    while (next_s_ <= t_s + 1e-9) next_s_ += period_s_;
  }
  double period_s() const { return period_s_; }

 private:
  double period_s_;
  double next_s_{0.0};
};

// ---------------------------------------------------------------------------------- IMU
struct ImuParams {
  double rate_hz{250.0};                  ///< sample rate (Hz)
  double latency_s{0.0};                  ///< delivery latency (s)
  double gravity_mps2{9.81};              ///< |g| used for the specific force (m/s^2)
  double gyro_noise_std_radps{0.003};     ///< white noise per sample (rad/s)
  double accel_noise_std_mps2{0.03};      ///< white noise per sample (m/s^2)
  double gyro_bias_init_std_radps{0.005}; ///< std of the turn-on bias (rad/s)
  double accel_bias_init_std_mps2{0.05};  ///< std of the turn-on bias (m/s^2)
  double gyro_bias_rw_radps_per_sqrts{1e-4};   ///< bias random walk (rad/s/sqrt(s))
  double accel_bias_rw_mps2_per_sqrts{1e-3};   ///< bias random walk (m/s^2/sqrt(s))
  Eigen::Vector3d misalignment_rad{Eigen::Vector3d::Zero()};  ///< the IMU's axes rotated off B
                                          ///< by roll, pitch, yaw about B's x, y, z (rad):
                                          ///< readings are R_SB (truth in B); YAML
                                          ///< misalignment_deg

  void validate() const {
    check_fields(*this);
    require(misalignment_rad.cwiseAbs().maxCoeff() <= M_PI / 18, "misalignment_deg",
            "each angle must be within +-10 deg");
  }
};

template <class V>
void visit_fields(V& v, ImuParams& p) {
  v("rate_hz", p.rate_hz, range::positive, "Hz", "sample rate");
  v("latency_ms", p.latency_s, range::non_negative, "ms", "delivery latency", 1e-3);
  v("gravity_mps2", p.gravity_mps2, range::positive, "m/s^2", "|g| used for the specific force");
  v("gyro_noise_std_radps", p.gyro_noise_std_radps, range::non_negative, "rad/s",
    "white noise per sample");
  v("accel_noise_std_mps2", p.accel_noise_std_mps2, range::non_negative, "m/s^2",
    "white noise per sample");
  v("gyro_bias_init_std_radps", p.gyro_bias_init_std_radps, range::non_negative, "rad/s",
    "std of the turn-on bias");
  v("accel_bias_init_std_mps2", p.accel_bias_init_std_mps2, range::non_negative, "m/s^2",
    "std of the turn-on bias");
  v("gyro_bias_rw_radps_per_sqrts", p.gyro_bias_rw_radps_per_sqrts, range::non_negative, "rad/s/sqrt(s)",
    "bias random walk");
  v("accel_bias_rw_mps2_per_sqrts", p.accel_bias_rw_mps2_per_sqrts, range::non_negative, "m/s^2/sqrt(s)",
    "bias random walk");
  v("misalignment_deg", p.misalignment_rad, range::any, "deg",
    "the IMU's axes rotated off B by roll", M_PI / 180.0);
}

class ImuModel {
 public:
  ImuModel(const ImuParams& p, std::uint64_t seed);  // validates p, draws turn-on biases
  bool due(double t_s) const { return clock_.due(t_s); }
  ImuSample sample(const VehicleTruth& truth);       // stamped truth.t_s
  const Eigen::Vector3d& gyro_bias_B() const { return b_g_; }
  const Eigen::Vector3d& accel_bias_B() const { return b_a_; }
  const ImuParams& params() const { return p_; }

 private:
  ImuParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  RateClock clock_;
  Eigen::Vector3d b_g_, b_a_;
  double last_t_s_{-1.0};
};

// ------------------------------------------------------------------------------ Barometer
struct BaroParams {
  double rate_hz{50.0};              ///< sample rate (Hz)
  double latency_s{0.02};            ///< delivery latency (s)
  double origin_msl_m{0.0};          ///< altitude of the W origin above sea level (m)
  double bias_mean_m{0.0};           ///< mean of the constant bias eps_b (eq. 9) (m)
  double bias_std_m{1.0};            ///< std of eps_b, drawn once per run (m)
  double noise_std_m{0.15};          ///< white noise w_q (eq. 9), altitude equivalent (m)
  double drift_rw_m_per_sqrts{0.005};///< slow drift, random walk (m/sqrt(s))
  double downwash_error_m{-0.5};     ///< downwash error at the surface, hover thrust (m)
  double downwash_decay_m{1.0};      ///< e-folding height of the downwash error (m)
  double hover_thrust_fraction{0.5}; ///< thrust fraction at which downwash_error_m applies

  void validate() const {
    check_fields(*this);
  }
};

template <class V>
void visit_fields(V& v, BaroParams& p) {
  v("rate_hz", p.rate_hz, range::positive, "Hz", "sample rate");
  v("latency_ms", p.latency_s, range::non_negative, "ms", "delivery latency", 1e-3);
  v("origin_msl_m", p.origin_msl_m,
    range::open(-400, 10000).because("within the ISA troposphere"), "m", "altitude of the W origin above sea level");
  v("bias_mean_m", p.bias_mean_m, range::any, "m", "mean of the constant bias eps_b (eq. 9)");
  v("bias_std_m", p.bias_std_m, range::non_negative, "m", "std of eps_b, drawn once per run");
  v("noise_std_m", p.noise_std_m, range::non_negative, "m", "white noise w_q (eq. 9)");
  v("drift_rw_m_per_sqrts", p.drift_rw_m_per_sqrts, range::non_negative, "m/sqrt(s)",
    "slow drift, random walk");
  v("downwash_error_m", p.downwash_error_m, range::any, "m", "downwash error at the surface");
  v("downwash_decay_m", p.downwash_decay_m, range::positive, "m",
    "e-folding height of the downwash error");
  v("hover_thrust_fraction", p.hover_thrust_fraction, range::open_closed(0, 1), "",
    "thrust fraction at which downwash_error_m applies");
}

class BaroModel {
 public:
  BaroModel(const BaroParams& p, std::uint64_t seed);  // validates p, draws eps_b
  bool due(double t_s) const { return clock_.due(t_s); }
  BaroSample sample(const VehicleTruth& truth);        // stamped truth.t_s
  // Altitude error of the last sample (m): bias + drift + downwash + noise.
  double last_error_m() const { return last_error_m_; }
  double bias_m() const { return bias_m_; }             // eps_b of this run
  double drift_m() const { return drift_m_; }
  // Downwash/ground-effect altitude error (m) at height h above the surface below.
  double downwash_error_m(double h_surface_m, double thrust_fraction) const;
  const BaroParams& params() const { return p_; }

 private:
  BaroParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  RateClock clock_;
  double bias_m_{0.0}, drift_m_{0.0}, last_error_m_{0.0};
  double last_t_s_{-1.0};
};

// ------------------------------------------------------------------------------------ GPS
struct GpsParams {
  double rate_hz{5.0};                 ///< fix rate (Hz), 5-10 for small receivers
  double latency_s{0.1};               ///< delivery latency (s)
  double horizontal_std_m{0.7};        ///< stationary std of the x, y error (m)
  double vertical_std_m{1.2};          ///< stationary std of the z error (m)
  double correlation_time_s{10.0};     ///< Gauss-Markov correlation time of the error (s)
  double velocity_std_mps{0.1};        ///< white velocity noise per axis (m/s)
  double glitch_rate_per_s{0.0};       ///< mean rate of random glitches (1/s)
  double glitch_std_m{3.0};            ///< per-axis std of a glitch offset (m)
  double glitch_duration_s{2.0};       ///< glitch length (s)
  double dropout_rate_per_s{0.0};      ///< mean rate of drop-outs (1/s)
  double dropout_duration_s{3.0};      ///< drop-out length (s)

  void validate() const {
    check_fields(*this);
  }
};

template <class V>
void visit_fields(V& v, GpsParams& p) {
  v("rate_hz", p.rate_hz, range::open_closed(0, 50), "Hz", "fix rate, 5-10 for small receivers");
  v("latency_ms", p.latency_s, range::non_negative, "ms", "delivery latency", 1e-3);
  v("horizontal_std_m", p.horizontal_std_m, range::non_negative, "m", "stationary std of the x");
  v("vertical_std_m", p.vertical_std_m, range::non_negative, "m", "stationary std of the z error");
  v("correlation_time_s", p.correlation_time_s, range::positive, "s",
    "Gauss-Markov correlation time of the error");
  v("velocity_std_mps", p.velocity_std_mps, range::non_negative, "m/s",
    "white velocity noise per axis");
  v("glitch_rate_per_s", p.glitch_rate_per_s, range::non_negative, "s",
    "mean rate of random glitches");
  v("glitch_std_m", p.glitch_std_m, range::non_negative, "m", "per-axis std of a glitch offset");
  v("glitch_duration_s", p.glitch_duration_s, range::non_negative, "s", "glitch length");
  v("dropout_rate_per_s", p.dropout_rate_per_s, range::non_negative, "s", "mean rate of drop-outs");
  v("dropout_duration_s", p.dropout_duration_s, range::non_negative, "s", "drop-out length");
}

class GpsModel {
 public:
  GpsModel(const GpsParams& p, std::uint64_t seed);  // validates p; error starts stationary
  bool due(double t_s) const { return clock_.due(t_s); }
  GpsSample sample(const VehicleTruth& truth);       // stamped truth.t_s
  // Scripted fault: adds offset_W_m to the position for t in [t_start_s, t_start_s + dur).
  void inject_offset(double t_start_s, double duration_s, const Eigen::Vector3d& offset_W_m);
  // Correlated (Gauss-Markov) part of the position error after the last sample (m).
  const Eigen::Vector3d& correlated_error_W_m() const { return err_W_; }
  const GpsParams& params() const { return p_; }

 private:
  struct Offset {
    double t0, t1;
    Eigen::Vector3d d;
  };
  GpsParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  std::uniform_real_distribution<double> u_{0.0, 1.0};
  RateClock clock_;
  Eigen::Vector3d sigma_W_;
  Eigen::Vector3d err_W_{Eigen::Vector3d::Zero()};
  std::vector<Offset> offsets_;
  double glitch_until_s_{-1.0};
  Eigen::Vector3d glitch_W_{Eigen::Vector3d::Zero()};
  double dropout_until_s_{-1.0};
  double last_t_s_{-1.0};
};

// ----------------------------------------------------------------------------- Ultrasonic
struct UltrasonicParams {
  double rate_hz{20.0};            ///< ping rate (Hz)
  double latency_s{0.01};          ///< delivery latency (s)
  double min_range_m{0.15};        ///< lower end of the valid range (m), Mini-S (seed 004 3.4)
  double max_range_m{3.05};        ///< upper end of the valid range (m)
  double noise_std_m{0.003};       ///< white noise inside the range (m), "about 3 mm"
  double garbage_scale_m{5.0};     ///< scale of |Cauchy| garbage outside the range (m)
  double glitch_prob{0.0};         ///< probability of a garbage value inside the range (-)

  void validate() const {
    check_fields(*this);
    require(max_range_m > min_range_m, "max_range_m", "must be > min_range_m");
  }
};

template <class V>
void visit_fields(V& v, UltrasonicParams& p) {
  v("rate_hz", p.rate_hz, range::positive, "Hz", "ping rate");
  v("latency_ms", p.latency_s, range::non_negative, "ms", "delivery latency", 1e-3);
  v("min_range_m", p.min_range_m, range::non_negative, "m", "lower end of the valid range");
  v("max_range_m", p.max_range_m, range::any, "m", "upper end of the valid range");
  v("noise_std_m", p.noise_std_m, range::non_negative, "m", "white noise inside the range");
  v("garbage_scale_m", p.garbage_scale_m, range::positive, "m",
    "scale of |Cauchy| garbage outside the range");
  v("glitch_prob", p.glitch_prob, range::closed(0, 1), "probability",
    "probability of a garbage value inside the range");
}

class UltrasonicModel {
 public:
  UltrasonicModel(const UltrasonicParams& p, std::uint64_t seed);  // validates p
  bool due(double t_s) const { return clock_.due(t_s); }
  UltrasonicSample sample(const VehicleTruth& truth);  // uses truth.range_m
  // Scripted fault: every sample in [t_start_s, t_start_s + duration_s) is garbage.
  void inject_garbage(double t_start_s, double duration_s);
  bool last_was_garbage() const { return last_garbage_; }
  const UltrasonicParams& params() const { return p_; }

 private:
  double garbage();
  UltrasonicParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  std::uniform_real_distribution<double> u_{0.0, 1.0};
  std::cauchy_distribution<double> cauchy_{0.0, 1.0};
  RateClock clock_;
  std::vector<std::pair<double, double>> bursts_;
  bool last_garbage_{false};
};

// All sensor params together (models/sensors_default.yaml has this layout).
// ------------------------------------------------------------------------- magnetometer
// Three-axis magnetometer: R_WB^T m_W + hard-iron bias + white noise. A flight controller's
// compass: what makes yaw observable (without it, yaw is the gyro integral and drifts).
struct MagnetometerParams {
  double rate_hz{50.0};                               ///< sample rate (Hz)
  double latency_s{0.0};                              ///< delivery latency (s)
  Eigen::Vector3d field_W_uT{22.0, 2.0, -42.0};       ///< local field in W (uT), mid-latitude
  double noise_std_uT{0.3};                           ///< white noise per axis (uT)
  double bias_std_uT{0.5};                            ///< residual hard-iron bias after calibration, std (uT)
  double declination_rad{0.0};  ///< the true field's horizontal part rotated about W z by this
                                ///< from field_W_uT (rad), counter-clockwise seen from above:
                                ///< a local declination the flight software's reference lacks;
                                ///< YAML declination_deg
  // The field the vehicle is in: field_W_uT with the declination applied.
  Eigen::Vector3d true_field_W_uT() const;
  void validate() const {
    check_fields(*this);
    require(std::abs(declination_rad) <= M_PI, "declination_deg", "must be within +-180 deg");
    require(field_W_uT.head<2>().norm() > 1.0, "field_W_uT", "needs a horizontal component (uT)");
  }
};

template <class V>
void visit_fields(V& v, MagnetometerParams& p) {
  v("rate_hz", p.rate_hz, range::positive, "Hz", "sample rate");
  v("latency_ms", p.latency_s, range::non_negative, "ms", "delivery latency", 1e-3);
  v("field_W_uT", p.field_W_uT, range::any, "uT", "local field in W");
  v("noise_std_uT", p.noise_std_uT, range::non_negative, "uT", "white noise per axis");
  v("bias_std_uT", p.bias_std_uT, range::non_negative, "uT",
    "residual hard-iron bias after calibration");
  v("declination_deg", p.declination_rad, range::any, "deg",
    "the true field's horizontal part rotated about W z", M_PI / 180.0);
}

class MagnetometerModel {
 public:
  MagnetometerModel(const MagnetometerParams& p, std::uint64_t seed);  // validates p, draws bias
  bool due(double t_s) const { return clock_.due(t_s); }
  MagSample sample(const VehicleTruth& truth);  // stamped truth.t_s
  const Eigen::Vector3d& bias_B_uT() const { return bias_; }

 private:
  MagnetometerParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  RateClock clock_;
  Eigen::Vector3d bias_{Eigen::Vector3d::Zero()};
};

// ------------------------------------------------------------------- platform telemetry
// The landing platform's broadcast: the cart's own GNSS receiver (a GpsModel on the
// platform's truth: Gauss-Markov position error, velocity noise, drop-outs of the fix) sent
// over a radio link to the vehicle, as a ship or a ground vehicle broadcasts its position.
// The message is stamped with its sampling time (GNSS time); it arrives gnss.latency_ms
// later (receiver and radio together), and each message is lost on the link with
// probability message_loss_prob. Off by default: the flight software then has no prior of
// where the cart is and searches around its own start.
struct PlatformTelemetryParams {
  bool enabled{false};           ///< the platform broadcasts (and the vehicle receives)
  double message_loss_prob{0.0}; ///< probability that one message is lost on the link (-)
  GpsParams gnss{default_gnss()};///< the platform's receiver; latency_ms includes the radio

  static GpsParams default_gnss() {
    GpsParams g;
    g.latency_s = 0.25;  // 100 ms in the receiver, ~150 ms on a telemetry radio
    return g;
  }
  void validate() const;
};

template <class V>
void visit_fields(V& v, PlatformTelemetryParams& p) {
  v("enabled", p.enabled, range::any, "", "the platform broadcasts (and the vehicle receives)");
  v("message_loss_prob", p.message_loss_prob, range::closed(0, 1), "probability",
    "probability that one message is lost on the link");
  v.nested("gnss", p.gnss);
}

class PlatformTelemetryModel {
 public:
  PlatformTelemetryModel(const PlatformTelemetryParams& p, std::uint64_t seed);  // validates p
  bool due(double t_s) const { return p_.enabled && gnss_.due(t_s); }
  // The platform's fix (stamped platform.t_s), or nothing when the link lost it.
  std::optional<GpsSample> sample(const PlatformTruth& platform);
  const PlatformTelemetryParams& params() const { return p_; }
  long lost() const { return lost_; }  ///< messages lost on the link so far

 private:
  PlatformTelemetryParams p_;
  GpsModel gnss_;
  std::mt19937_64 link_rng_;
  std::uniform_real_distribution<double> u_{0.0, 1.0};
  long lost_{0};
};

struct SensorSuiteParams {
  ImuParams imu;
  BaroParams baro;
  GpsParams gps;
  UltrasonicParams ultrasonic;
  MagnetometerParams magnetometer;
  PlatformTelemetryParams platform_telemetry;  ///< not the vehicle's: the platform's broadcast
  // Throws ConfigError whose message names the sensor and the field ("baro: ...").
  void validate() const;
};

template <class V>
void visit_fields(V& v, SensorSuiteParams& p) {
  v.nested("imu", p.imu);
  v.nested("baro", p.baro);
  v.nested("gps", p.gps);
  v.nested("ultrasonic", p.ultrasonic);
  v.nested("magnetometer", p.magnetometer);
  v.nested("platform_telemetry", p.platform_telemetry);
}

// Derives the seed of one random stream ("imu", "camera", ...) from the scenario seed
// (FNV-1a of the name mixed with the seed through SplitMix64's finaliser): the same scenario
// seed always gives the same streams, and each stream is independent of the others.
std::uint64_t derive_seed(std::uint64_t scenario_seed, const std::string& stream);

// The sensor rig: the five sensors with their delivery queues, seeded from one scenario seed
// (streams "imu", "baro", "gps", "ultrasonic", "magnetometer" of derive_seed). Per physics step
// the loop calls sample(truth) (samples every sensor that is due, as it measures), may look at
// or corrupt what was sampled (metrics, fault hooks), transmit()s it (queued for t + latency),
// and then deliver(t) (everything whose delivery time has come, in sampling order per sensor).
class SensorSuite {
 public:
  struct Sampled {  ///< the samples taken at one instant (absent: that sensor was not due)
    std::optional<ImuSample> imu;
    std::optional<BaroSample> baro;
    std::optional<GpsSample> gps;
    std::optional<UltrasonicSample> ultrasonic;
    std::optional<MagSample> magnetometer;
    std::optional<GpsSample> platform_telemetry;  ///< the platform's broadcast (not lost)
  };
  struct Delivered {
    std::vector<ImuSample> imu;
    std::vector<BaroSample> baro;
    std::vector<GpsSample> gps;
    std::vector<UltrasonicSample> ultrasonic;
    std::vector<MagSample> magnetometer;
    std::vector<GpsSample> platform_telemetry;
    bool empty() const {
      return imu.empty() && baro.empty() && gps.empty() && ultrasonic.empty() && magnetometer.empty() &&
             platform_telemetry.empty();
    }
  };
  SensorSuite(const SensorSuiteParams& p, std::uint64_t scenario_seed);  // validates p
  // `platform`: the platform's truth for its broadcast (sensors.platform_telemetry); without it
  // (or with the broadcast off) no telemetry is sampled.
  Sampled sample(const VehicleTruth& truth, const PlatformTruth* platform = nullptr);
  void transmit(const Sampled& s);  // queues each sample for its sampling time + latency
  Delivered deliver(double t_s);
  ImuModel& imu() { return imu_; }
  BaroModel& baro() { return baro_; }
  GpsModel& gps() { return gps_; }                  // e.g. gps().inject_offset(...)
  UltrasonicModel& ultrasonic() { return us_; }     // e.g. ultrasonic().inject_garbage(...)
  MagnetometerModel& magnetometer() { return mag_; }
  PlatformTelemetryModel& platform_telemetry() { return telemetry_; }
  const SensorSuiteParams& params() const { return p_; }

 private:
  SensorSuiteParams p_;
  ImuModel imu_;
  MagnetometerModel mag_;
  BaroModel baro_;
  GpsModel gps_;
  UltrasonicModel us_;
  PlatformTelemetryModel telemetry_;
  DelayQueue<ImuSample> q_imu_;
  DelayQueue<BaroSample> q_baro_;
  DelayQueue<GpsSample> q_gps_;
  DelayQueue<UltrasonicSample> q_us_;
  DelayQueue<MagSample> q_mag_;
  DelayQueue<GpsSample> q_telemetry_;
};

}  // namespace lander::sim
