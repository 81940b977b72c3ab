// Altitude fusion (seed 004 section 4) and the barometric altitude formula (seed 004 eq. 8).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/params_io.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander {

// ------------------------------------------------------------------ ISA, seed 004 eq. 8
// International Standard Atmosphere, troposphere (0-11 km):
//   H = T_b / beta [ (P_H / P_b)^(-beta r / g_n) - 1 ] + H_b                        (eq. 8)
// with T_b = 288.15 K, P_b = 101325 Pa, H_b = 0 m, beta = -0.0065 K/m (temperature lapse
// dT/dH), r = 287.05287 J/(kg K), g_n = 9.80665 m/s^2. The inverse gives P_H from H.
struct IsaConstants {
  static constexpr double kTb_K = 288.15;
  static constexpr double kPb_Pa = 101325.0;
  static constexpr double kHb_m = 0.0;
  static constexpr double kBeta_K_per_m = -0.0065;
  static constexpr double kR_J_per_kgK = 287.05287;
  static constexpr double kGn_mps2 = 9.80665;
};
// Geopotential altitude above sea level (m) from static pressure (Pa), eq. 8.
double isa_altitude_m(double pressure_pa);
// Static pressure (Pa) at altitude above sea level (m), the inverse of eq. 8.
double isa_pressure_pa(double altitude_m);

// ------------------------------------------------------------------- fusion parameters
struct AltitudeFusionParams {
  // Barometer reference: altitude of the W origin above sea level (m); the barometric
  // altitude in W is isa_altitude_m(p) - baro_origin_msl_m (its error is the bias state).
  double baro_origin_msl_m{0.0};
  // Measurement noise std (the diagonal of R, eq. 22) per sensor (m).
  double baro_std_m{0.15};
  double gps_std_m{1.2};            ///< std of the time-correlated GPS height error (m)
  double gps_corr_time_s{10.0};     ///< its correlation time (s), Gauss-Markov
  double gps_white_std_m{0.1};      ///< white part of the GPS height noise (m)
  double ultrasonic_std_m{0.005};
  double vision_std_m{0.05};        ///< used when update_vision is called without a std
  // Process noise (Q, eq. 21), as continuous-time densities.
  double accel_noise_mps2{0.03};    ///< white vertical-accel noise density (m/s^2/sqrt(Hz))
  double accel_bias_rw_mps3{0.01};  ///< vertical accel bias random walk (m/s^2/sqrt(s))
  double baro_bias_rw_mps{0.01};    ///< baro bias drift, random walk (m/sqrt(s))
  double surface_rw_mps{0.02};      ///< surface height below changes (terrain) (m/sqrt(s))
  double platform_rw_mps{0.002};    ///< target plane height (cart bounces) (m/sqrt(s))
  // A surface that moves (a boat's deck heaving decimetres at up to ~0.5 m/s): the surface
  // and target-plane states random-walk at this rate instead (m/sqrt(s)), so the ultrasonic
  // and vision measure the height over the moving deck without moving z and vz with it, and
  // the barometer stays fused in the eq. 17 set as the height's anchor (its downwash error
  // near the deck then enters the height; the landing servoes on vision's clearance). With a
  // still surface's random walk the heave went into z: on sea state 3 the vertical velocity
  // carried +-0.5 m/s of the deck's. 0 = the surface is still (seed 004's model).
  double moving_surface_rw_mps{0.0};
  // Initial uncertainty (P_0).
  double initial_baro_bias_std_m{3.0};
  double initial_accel_bias_std_mps2{0.2};
  double platform_height_m{0.8};      ///< prior height of the target plane in W (m)
  double platform_height_std_m{0.02}; ///< its std (m): a surveyed, modelled platform
  // Measurement-set switch (eq. 15-18): below this estimated height above the surface the
  // ultrasonic set (eq. 17) is used, above it the baro set (eq. 15).
  double switch_height_m{3.0};
  double switch_hysteresis_m{0.1};
  // The eq. 17 set takes the ultrasonic instead of the barometer. When the ultrasonic has
  // given no trusted reading for this long in it (s: since the set came in force, or since
  // the last), the barometer is fused again: a height believed low while the ranger sees
  // nothing in range (metres of GPS error taken in at the start: the vehicle at 6 m) would
  // otherwise follow the GPS alone, and a 3 m/s descent went unseen. 0 = never (the paper's
  // switch as is).
  double baro_fallback_s{1.0};
  // Ultrasonic readings outside [min, max] are rejected (seed 004 eq. 12: garbage).
  double ultrasonic_min_m{0.15};
  double ultrasonic_max_m{3.05};
  // Residual gate (eq. 27): a residual component beyond gate_sigma * sqrt(P~) has its gain
  // multiplied by gate_factor_n (the paper's n in [0, 1], 2 sigma in the paper).
  double gate_sigma{2.0};
  double gate_factor_n{0.1};
  // Seed 004 sec. 4.3: "when the residual is very large, K* is set to zero". Beyond
  // reject_sigma sqrt(P~) a component is dropped, unless reject_limit samples of that sensor
  // in a row were dropped (then eq. 27's n K again, so a diverged filter cannot lock out).
  double reject_sigma{5.0};
  int reject_limit{25};
  // Surface-step detector for the ultrasonic (platform edge, and acquisition when coming
  // down into range): a gated residual of at least step_min_m is a step candidate;
  // step_count consecutive candidates whose heights agree within step_agree_m re-reference
  // the surface instead of moving the height. Steps above surface_step_max_m are garbage.
  double step_min_m{0.1};
  int step_count{3};
  double step_agree_m{0.05};
  double surface_step_max_m{2.0};
  // Height reset: the world under the vehicle is the ground or the platform, never a step of
  // more than surface_step_max_m above the surface the filter believes. When this many
  // consecutive in-range ultrasonic readings agree (each implying a surface within step_agree_m
  // of the previous one's, the readings' heights taken against the height's own motion in
  // between, so a climb or descent chains; 20 Hz: 1 s) on such a step, it is the height
  // that is wrong (a degraded GPS's vertical error taken in at the start), not the world: the
  // height is set from the readings over the surface believed, the barometer-bias and GPS-
  // error states take the difference, and the eq. 17 set comes in force. 0 = off.
  int height_reset_count{20};
  // Clearance (AltitudeEstimate::clearance_m): this many consecutive in-range readings that
  // agree as above give the height over what is below, whatever the filter believes about
  // the surface (the controller's floor in the search). |Cauchy| garbage (eq. 12) chains with
  // a probability of about 1e-8 per reading at 5. It lapses when the last reading is older
  // than max_sample_age_ms. 0 = never.
  int clearance_count{5};
  // Latency compensation: a sample older than this is dropped (s).
  double max_sample_age_s{0.5};

  void validate() const;
};

template <class V>
void visit_fields(V& v, AltitudeFusionParams& p) {
  v("baro_origin_msl_m", p.baro_origin_msl_m, range::any, "m", "Barometer reference");
  v("baro_std_m", p.baro_std_m, range::positive, "m",
    "Measurement noise std (the diagonal of R, eq. 22) per sensor");
  v("gps_std_m", p.gps_std_m, range::positive, "m", "std of the time-correlated GPS height error");
  v("gps_corr_time_s", p.gps_corr_time_s, range::positive, "s", "its correlation time");
  v("gps_white_std_m", p.gps_white_std_m, range::positive, "m",
    "white part of the GPS height noise");
  v("ultrasonic_std_m", p.ultrasonic_std_m, range::positive, "m", "");
  v("vision_std_m", p.vision_std_m, range::positive, "m",
    "used when update_vision is called without a std");
  v("accel_noise_mps2", p.accel_noise_mps2, range::positive, "m/s^2",
    "white vertical-accel noise density (m/s^2/sqrt)");
  v("accel_bias_rw_mps3", p.accel_bias_rw_mps3, range::non_negative, "m/s^3",
    "vertical accel bias random walk (m/s^2/sqrt)");
  v("baro_bias_rw_mps", p.baro_bias_rw_mps, range::non_negative, "m/s", "baro bias drift");
  v("surface_rw_mps", p.surface_rw_mps, range::non_negative, "m/s",
    "surface height below changes (m/sqrt)");
  v("platform_rw_mps", p.platform_rw_mps, range::non_negative, "m/s",
    "target plane height (cart bounces) (m/sqrt)");
  v("moving_surface_rw_mps", p.moving_surface_rw_mps, range::non_negative, "m/s",
    "a moving surface (boat deck): its random walk (m/sqrt); 0 = still");
  v("initial_baro_bias_std_m", p.initial_baro_bias_std_m, range::positive, "m",
    "Initial uncertainty");
  v("initial_accel_bias_std_mps2", p.initial_accel_bias_std_mps2, range::positive, "m/s^2", "");
  v("platform_height_m", p.platform_height_m, range::any, "m",
    "prior height of the target plane in W");
  v("platform_height_std_m", p.platform_height_std_m, range::positive, "m", "its std: a surveyed");
  v("switch_height_m", p.switch_height_m, range::positive, "m",
    "Measurement-set switch (eq. 15-18)");
  v("switch_hysteresis_m", p.switch_hysteresis_m, range::any, "m", "");
  v("baro_fallback_s", p.baro_fallback_s, range::non_negative, "s",
    "The eq. 17 set takes the ultrasonic instead of the barometer");
  v("ultrasonic_min_m", p.ultrasonic_min_m, range::non_negative, "m",
    "Ultrasonic readings outside [min");
  v("ultrasonic_max_m", p.ultrasonic_max_m, range::any, "m", "");
  v("gate_sigma", p.gate_sigma, range::positive, "", "Residual gate (eq. 27)");
  v("gate_factor_n", p.gate_factor_n, range::closed(0, 1).because("eq. 27"), "N", "");
  v("reject_sigma", p.reject_sigma, range::any, "", "residual beyond which a sample is rejected (sigma)");
  v("reject_limit", p.reject_limit, range::non_negative, "", "");
  v("step_min_m", p.step_min_m, range::positive, "m", "Surface-step detector for the ultrasonic");
  v("step_count", p.step_count, range::closed(1, 8), "", "");
  v("step_agree_m", p.step_agree_m, range::positive, "m", "");
  v("surface_step_max_m", p.surface_step_max_m, range::any, "m", "");
  v("height_reset_count", p.height_reset_count, range::non_negative, "",
    "Height reset: the world under the vehicle is the ground");
  v("clearance_count", p.clearance_count, range::non_negative, "",
    "Clearance (AltitudeEstimate::clearance_m)");
  v("max_sample_age_ms", p.max_sample_age_s, range::positive, "ms", "Latency compensation", 1e-3);
}

// Vertical acceleration in W (m/s^2, gravity removed) from an IMU specific force and the
// attitude: a_z = (R_WB f_B).z - g.
double vertical_accel_W(const ImuSample& imu, const Eigen::Quaterniond& q_WB,
                        double gravity_mps2 = 9.81);

// The adaptive Kalman filter of seed 004 section 4, for a multirotor.
//
// State x = [z, vz, eps_b, b_a, s, c]:
//   z     height of B in W (m) (the paper's h_0),
//   vz    vertical velocity (m/s),
//   eps_b barometer bias (m) (eq. 9),
//   b_a   vertical accelerometer bias (m/s^2),
//   s     height in W of the surface straight below (ground or platform top) (m),
//   c     height in W of the target plane (platform top) seen by vision (m),
//   g     GPS height error (m): first-order Gauss-Markov (gps_std_m, gps_corr_time_s), as
//         real receivers' errors are correlated over many seconds (seed 004 eq. 10 calls it
//         white; treated as white, 60 s of 5 Hz fixes would look 300x more informative than
//         they are and pull z by their slow error).
// Seed 004 predicts h with its helicopter model eq. 13-14 (main-rotor speed and collective
// pitch). That model does not fit a multirotor (no collective, six fixed-pitch rotors), so
// here the prediction (eq. 19) integrates the IMU's vertical acceleration instead:
//   z += vz dt + (a - b_a) dt^2/2,  vz += (a - b_a) dt,  eps_b, b_a, s, c constant (+ noise).
// Measurements (rows of H, eq. 15 and 17, extended by the surface states):
//   baro        h_q = z + eps_b        (eq. 9; used above the switch height, eq. 15)
//   GPS         h_g = z + g            (eq. 10 + correlated error; both sets)
//   ultrasonic  h_c = z - s            (eq. 12; below the switch height only, eq. 17)
//   vision      h_v = z - c            (eq. 7 / ring pose; both sets)
// The paper stacks the components of one epoch; our sensors arrive at their own rates, so
// each arriving component is one scalar update with its row of H (equal to the stacked
// update for independent noises). Each component is gated as in eq. 27: with residual
// r = Z - H x (eq. 25) and P~ = H P H^T + R (eq. 26), the gain is K if |r| <= 2 sqrt(P~),
// else n K, and 0 beyond reject_sigma sqrt(P~) (the paper's "very large residual"). Late samples (stamped t < now) are compared with the state moved back by
// vz (now - t) (first-order latency compensation).
//
// Platform edge: ultrasonic measures z - s, not z, so when the vehicle crosses the edge the
// reading jumps by the platform height while z does not move. The jump is a large residual,
// gated by eq. 27 and offered to a step detector instead of being applied; step_count
// consecutive agreeing values re-reference the surface, s = z - mean(h_c), with s's
// covariance rebuilt from z's (s is then known only relative to z), leaving z and vz
// untouched: the height in W shows no spike and the height above the surface jumps as the
// truth does, after step_count pings. Gated residuals smaller than step_min_m get n K.
// After any garbage (out of range, or a large residual), readings are held until
// step_count of them in a row pass the gate (gated ones restart the count), so a garbage
// value that happens to fall near the prediction is not taken for the surface.
// Coming down into range in the eq. 15 set, the surface below is not known (s was last seen
// long ago, or never: the platform); in-range readings are acquisition candidates and
// step_count agreeing ones switch to the eq. 17 set and re-reference s the same way. While
// in the eq. 17 set, s random-walks slowly (surface_rw_mps, gentle terrain); over a moving
// deck (moving_surface_rw_mps > 0) s and c random-walk fast and the barometer stays fused.
class AltitudeFusion {
 public:
  enum class Outcome {
    kAccepted,       ///< normal update, full gain
    kGated,          ///< residual beyond the gate: gain n K (eq. 27)
    kRejectedOutlier,///< residual beyond reject_sigma: gain 0 (sec. 4.3)
    kRejectedRange,  ///< ultrasonic outside its valid range (eq. 12)
    kRejectedSet,    ///< sensor not in the active measurement set (eq. 15 / 17)
    kRejectedStale,  ///< sample older than max_sample_age_s, or from the future
    kStepPending,    ///< range residual held by the surface-step detector
    kSurfaceStep,    ///< surface re-referenced (platform edge)
    kHeightReset,    ///< height set from agreeing range readings (height_reset_count)
  };
  static constexpr int kZ = 0, kVz = 1, kBaroBias = 2, kAccelBias = 3, kSurface = 4, kPlane = 5,
                       kGpsErr = 6;
  static constexpr int kN = 7;
  using Vec = Eigen::Matrix<double, kN, 1>;
  using Mat = Eigen::Matrix<double, kN, kN>;

  explicit AltitudeFusion(const AltitudeFusionParams& p);  // validates p
  // Starts the filter at t_s with the vehicle at height z_W_m over a surface at surface_W_m
  // (e.g. on the ground before take-off: z = height of B's origin above its feet, s = 0),
  // known to z_std_m and surface_std_m.
  void reset(double t_s, double z_W_m, double surface_W_m = 0.0, double vz_W_mps = 0.0,
             double z_std_m = 0.05, double surface_std_m = 0.05);
  // Starts the filter in the air from a barometer sample: z = baro altitude in W, bias 0,
  // with z + eps_b known exactly but the split unknown (Var z = Var eps_b =
  // initial_baro_bias_std_m^2, fully anti-correlated); the surface below at surface_W_m
  // known to surface_std_m. Vision and GPS then sort out z and the bias.
  void reset_from_baro(const BaroSample& b, double surface_W_m = 0.0, double surface_std_m = 2.0);
  // Propagates to t_s (>= current time) with the vertical acceleration in W (m/s^2, gravity
  // removed) held over the interval. Calls with t_s <= current time do nothing; a non-finite
  // acceleration or time is skipped and counted (rejected_inputs), never thrown.
  void predict(double t_s, double az_W_mps2);
  // Convenience: predict with an IMU sample and the attitude estimate (also remembers the
  // tilt for the ultrasonic, see set_attitude). A non-finite attitude is skipped and counted.
  void predict(const ImuSample& imu, const Eigen::Quaterniond& q_WB, double gravity_mps2 = 9.81);
  // Prediction inputs skipped because they were not finite (every update_* refuses
  // non-finite measurements with kRejectedRange or kRejectedStale).
  long rejected_inputs() const { return rejected_inputs_; }
  // Attitude used to turn the slant ultrasonic range (along -z_B) into a vertical height:
  // h = range * (R_WB)_zz (flat surface assumed).
  void set_attitude(const Eigen::Quaterniond& q_WB);
  Outcome update_baro(const BaroSample& s);
  Outcome update_gps(const GpsSample& s);
  Outcome update_ultrasonic(const UltrasonicSample& s);
  // Vision height of B above the target plane (m), e.g. from altitude_vision.h, taken at t_s,
  // with its std (m); std_m <= 0 uses params.vision_std_m.
  Outcome update_vision(double t_s, double h_plane_m, double std_m = -1.0);

  AltitudeEstimate estimate() const;
  double time_s() const { return t_s_; }
  bool ultrasonic_set_active() const { return low_set_; }  // eq. 17 set in force
  long height_resets() const { return height_resets_; }     // see height_reset_count
  long baro_fallback_updates() const { return baro_fallbacks_; }  // see baro_fallback_s
  const Vec& x() const { return x_; }
  const Mat& P() const { return P_; }
  const AltitudeFusionParams& params() const { return p_; }

 private:
  using Row = Eigen::Matrix<double, 1, kN>;
  // Residual r = z - H x (eq. 25) and its variance P~ = H P H^T + R (eq. 26).
  void residual(const Row& H, double z, double R, double* r, double* S) const;
  // Applies K* (eq. 22, 23, 27) with gain scale (1 or n); Joseph form of eq. 24.
  void apply(const Row& H, double r, double R, double gain_scale);
  // Row of H with the latency compensation: H x - vz * age_s.
  Row row(std::initializer_list<std::pair<int, double>> entries, double age_s) const;
  // Gates one component (eq. 27) and applies it; returns kAccepted, kGated or
  // kRejectedOutlier. `sensor` indexes the consecutive-rejection counters.
  Outcome gated_update(const Row& H, double z, double R, int sensor);
  // Re-references the surface state: s = z - h_mean, with h_mean's variance var_m2.
  void rereference_surface(double h_mean_m, double var_m2);
  bool age_ok(double t_sample_s) const;
  void update_set();
  // update_ultrasonic's work; update_ultrasonic notes when the ultrasonic was last trusted.
  Outcome fuse_ultrasonic(const UltrasonicSample& s);
  // Adds a candidate height to the step detector; true (with mean and its variance) once
  // step_count consecutive candidates agree.
  bool collect_step(double h_now_m, double* mean_m, double* var_m2);

  AltitudeFusionParams p_;
  double t_s_{0.0};
  Vec x_{Vec::Zero()};
  Mat P_{Mat::Zero()};
  bool low_set_{true};
  double cos_tilt_{1.0};
  std::array<double, 8> step_buf_{};
  int step_n_{0};
  // A chain of consecutive ultrasonic readings whose implied surfaces (odo_z_ - h: a moving
  // vehicle's readings agree) each lie within a tolerance of the previous one's; a reading
  // that does not restarts it. Garbage (eq. 12) does not chain.
  struct AgreeingChain {
    int n{0};
    double sum{0.0}, sum2{0.0};  // of the implied surfaces
    double last{0.0};            // the last implied surface
    double last_t_s{0.0};        // and its sample time
    void add(double q, double t_s, double agree_m) {
      if (n > 0 && std::abs(q - last) > agree_m) n = 0;
      if (n == 0) sum = sum2 = 0.0;
      ++n;
      sum += q;
      sum2 += q * q;
      last = q;
      last_t_s = t_s;
    }
    void clear() { n = 0; }
    double mean() const { return sum / n; }
    double spread2() const { return std::max(0.0, sum2 / n - mean() * mean()); }
  };
  // Height reset (height_reset_count): readings that imply an impossible surface step.
  AgreeingChain reset_chain_;
  // Counts one such reading; true (with the mean height now and its variance) once there are
  // enough.
  bool collect_height_reset(double h_now_m, double* mean_m, double* var_m2);
  // Clearance (clearance_count): every in-range reading.
  AgreeingChain clear_chain_;
  // The height's own motion, dead-reckoned by predict() only (the chains' reference: a
  // measurement update or a reset moving z does not move what the readings saw).
  double odo_z_{0.0};
  // Sets the height to the surface + h_mean_m (see height_reset_count).
  void reset_height(double h_mean_m, double var_m2);
  long height_resets_{0};
  // baro_fallback_s: when the ultrasonic was last trusted (or the eq. 17 set came in force),
  // and the barometer samples fused in the set since.
  double us_trusted_t_s_{0.0};
  long baro_fallbacks_{0};
  void set_low(bool low);
  std::array<int, 3> rejects_{};  // consecutive outlier rejections: baro, GPS, vision
  bool us_suspect_{false};  // garbage seen since the last trusted ultrasonic reading
  int us_run_{0};           // consecutive in-gate readings while suspect
  long rejected_inputs_{0};
};

}  // namespace lander
