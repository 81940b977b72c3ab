#include "lander/estimator/altitude_fusion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lander {

// ------------------------------------------------------------------------------- ISA eq. 8
double isa_altitude_m(double pressure_pa) {
  using C = IsaConstants;
  if (!(pressure_pa > 0)) throw std::invalid_argument("isa_altitude_m: pressure must be > 0");
  const double expo = -C::kBeta_K_per_m * C::kR_J_per_kgK / C::kGn_mps2;
  return C::kTb_K / C::kBeta_K_per_m * (std::pow(pressure_pa / C::kPb_Pa, expo) - 1.0) +
         C::kHb_m;
}

double isa_pressure_pa(double altitude_m) {
  using C = IsaConstants;
  // Inverse of eq. 8: P = P_b (1 + beta (H - H_b) / T_b)^(-g_n / (beta r)).
  const double base = 1.0 + C::kBeta_K_per_m * (altitude_m - C::kHb_m) / C::kTb_K;
  if (!(base > 0)) throw std::invalid_argument("isa_pressure_pa: altitude outside the model");
  return C::kPb_Pa * std::pow(base, -C::kGn_mps2 / (C::kBeta_K_per_m * C::kR_J_per_kgK));
}

double vertical_accel_W(const ImuSample& imu, const Eigen::Quaterniond& q_WB,
                        double gravity_mps2) {
  return (q_WB * imu.accel_B_mps2).z() - gravity_mps2;
}

// ------------------------------------------------------------------------------ params
void AltitudeFusionParams::validate() const {
  check_fields(*this);
  require(switch_hysteresis_m >= 0 && switch_hysteresis_m < switch_height_m,
          "switch_hysteresis_m", "must be in [0, switch_height_m)");
  require(ultrasonic_max_m > ultrasonic_min_m, "ultrasonic_max_m", "must be > ultrasonic_min_m");
  require(reject_sigma > gate_sigma, "reject_sigma", "must be > gate_sigma");
  require(surface_step_max_m > step_min_m, "surface_step_max_m", "must be > step_min_m");
}

// ------------------------------------------------------------------------------ filter
AltitudeFusion::AltitudeFusion(const AltitudeFusionParams& p) : p_(p) {
  p_.validate();
  reset(0.0, 0.0, 0.0);
}

void AltitudeFusion::reset(double t_s, double z_W_m, double surface_W_m, double vz_W_mps,
                           double z_std_m, double surface_std_m) {
  if (!(z_std_m > 0) || !(surface_std_m > 0)) {
    throw std::invalid_argument("AltitudeFusion::reset: stds must be > 0");
  }
  const double kInitialZStd_m = z_std_m;
  constexpr double kInitialVzStd_mps = 0.1;  // at rest or hovering, to 0.1 m/s
  const double kInitialSurfaceStd_m = surface_std_m;
  t_s_ = t_s;
  x_.setZero();
  x_[kZ] = z_W_m;
  x_[kVz] = vz_W_mps;
  x_[kSurface] = surface_W_m;
  x_[kPlane] = p_.platform_height_m;
  P_.setZero();
  P_(kZ, kZ) = kInitialZStd_m * kInitialZStd_m;
  P_(kVz, kVz) = kInitialVzStd_mps * kInitialVzStd_mps;
  P_(kBaroBias, kBaroBias) = p_.initial_baro_bias_std_m * p_.initial_baro_bias_std_m;
  P_(kAccelBias, kAccelBias) = p_.initial_accel_bias_std_mps2 * p_.initial_accel_bias_std_mps2;
  P_(kSurface, kSurface) = kInitialSurfaceStd_m * kInitialSurfaceStd_m;
  P_(kPlane, kPlane) = p_.platform_height_std_m * p_.platform_height_std_m;
  P_(kGpsErr, kGpsErr) = p_.gps_std_m * p_.gps_std_m;
  low_set_ = (z_W_m - surface_W_m) < p_.switch_height_m;
  us_trusted_t_s_ = t_s;
  step_n_ = 0;
  reset_chain_.clear();
  clear_chain_.clear();
  us_suspect_ = false;
  us_run_ = 0;
  rejects_.fill(0);
}

void AltitudeFusion::reset_from_baro(const BaroSample& b, double surface_W_m,
                                     double surface_std_m) {
  if (!(b.pressure_pa > 0)) throw std::invalid_argument("reset_from_baro: bad pressure");
  const double h_q = isa_altitude_m(b.pressure_pa) - p_.baro_origin_msl_m;  // eq. 8
  const double sb = p_.initial_baro_bias_std_m;
  reset(b.t_s, h_q, surface_W_m, 0.0, sb, surface_std_m);
  // z + eps_b = h_q is known (to the baro noise); z and eps_b individually are not.
  P_(kZ, kBaroBias) = P_(kBaroBias, kZ) = -sb * sb + p_.baro_std_m * p_.baro_std_m;
  low_set_ = (h_q - surface_W_m) < p_.switch_height_m;
}

void AltitudeFusion::set_attitude(const Eigen::Quaterniond& q_WB) {
  cos_tilt_ = std::max(0.0, q_WB.toRotationMatrix()(2, 2));
}

void AltitudeFusion::predict(const ImuSample& imu, const Eigen::Quaterniond& q_WB,
                             double gravity_mps2) {
  if (!q_WB.coeffs().allFinite()) {
    ++rejected_inputs_;
    return;
  }
  set_attitude(q_WB);
  predict(imu.t_s, vertical_accel_W(imu, q_WB, gravity_mps2));
}

// Eq. 19 and 21 with the IMU-driven model (see the header for why not eq. 13):
//   x_{k+1|k} = F x_k + G a,   P_{k+1|k} = F P F^T + Q.
void AltitudeFusion::predict(double t_s, double az_W_mps2) {
  if (!std::isfinite(az_W_mps2) || !std::isfinite(t_s)) {  // a bad sample: skipped, never thrown
    ++rejected_inputs_;
    return;
  }
  const double dt = t_s - t_s_;
  if (!(dt > 0)) return;
  Mat F = Mat::Identity();
  F(kZ, kVz) = dt;
  F(kZ, kAccelBias) = -0.5 * dt * dt;
  F(kVz, kAccelBias) = -dt;
  const double a_g = std::exp(-dt / p_.gps_corr_time_s);
  F(kGpsErr, kGpsErr) = a_g;
  const double a = az_W_mps2 - x_[kAccelBias];
  const double dz = x_[kVz] * dt + 0.5 * a * dt * dt;
  x_[kZ] += dz;
  odo_z_ += dz;
  x_[kVz] += a * dt;
  x_[kGpsErr] *= a_g;
  // Q: white acceleration (density q) into [z, vz]; random walks on the other states.
  const double q = p_.accel_noise_mps2 * p_.accel_noise_mps2;
  Mat Q = Mat::Zero();
  Q(kZ, kZ) = q * dt * dt * dt / 3.0;
  Q(kZ, kVz) = Q(kVz, kZ) = q * dt * dt / 2.0;
  Q(kVz, kVz) = q * dt;
  Q(kBaroBias, kBaroBias) = p_.baro_bias_rw_mps * p_.baro_bias_rw_mps * dt;
  Q(kAccelBias, kAccelBias) = p_.accel_bias_rw_mps3 * p_.accel_bias_rw_mps3 * dt;
  const bool moving = p_.moving_surface_rw_mps > 0.0;
  const double surface_rw = moving ? std::max(p_.surface_rw_mps, p_.moving_surface_rw_mps) : p_.surface_rw_mps;
  const double plane_rw = moving ? std::max(p_.platform_rw_mps, p_.moving_surface_rw_mps) : p_.platform_rw_mps;
  Q(kSurface, kSurface) = surface_rw * surface_rw * dt;
  Q(kPlane, kPlane) = plane_rw * plane_rw * dt;
  Q(kGpsErr, kGpsErr) = p_.gps_std_m * p_.gps_std_m * (1.0 - a_g * a_g);
  P_ = F * P_ * F.transpose() + Q;
  t_s_ = t_s;
  update_set();
}

// Measurement-set switch at the ultrasonic limit (eq. 15-18), on the estimated height above
// the surface below, with hysteresis. (The paper switches on the ultrasonic reading itself;
// out of range that reading is garbage, eq. 12, and may well be < 3 m, so we do not.)
void AltitudeFusion::update_set() {
  const double h = x_[kZ] - x_[kSurface];
  if (low_set_ && h > p_.switch_height_m + p_.switch_hysteresis_m) set_low(false);
  if (!low_set_ && h < p_.switch_height_m - p_.switch_hysteresis_m) set_low(true);
}

void AltitudeFusion::set_low(bool low) {
  if (low && !low_set_) us_trusted_t_s_ = t_s_;  // the fallback's clock starts with the set
  low_set_ = low;
}

bool AltitudeFusion::age_ok(double t_sample_s) const {
  const double age = t_s_ - t_sample_s;
  constexpr double kFutureSlack_s = 1e-6;  // stamps equal to "now" up to rounding
  return age >= -kFutureSlack_s && age <= p_.max_sample_age_s;
}

AltitudeFusion::Row AltitudeFusion::row(std::initializer_list<std::pair<int, double>> entries,
                                        double age_s) const {
  Row H = Row::Zero();
  for (const auto& e : entries) H(e.first) += e.second;
  // The quantity at the sampling time t - age is H x - (dH/dz) vz age (first order).
  H(kVz) -= H(kZ) * std::max(0.0, age_s);
  return H;
}

void AltitudeFusion::residual(const Row& H, double z, double R, double* r, double* S) const {
  *r = z - H * x_;                              // eq. 25
  *S = (H * P_ * H.transpose())(0, 0) + R;      // eq. 26
}

void AltitudeFusion::apply(const Row& H, double r, double R, double gain_scale) {
  const double S = (H * P_ * H.transpose())(0, 0) + R;
  const Vec K = gain_scale * P_ * H.transpose() / S;  // eq. 22, scaled as eq. 27
  x_ += K * r;                                        // eq. 23
  // Eq. 24 in Joseph form, valid for the sub-optimal gain n K too.
  const Mat IKH = Mat::Identity() - K * H;
  P_ = IKH * P_ * IKH.transpose() + K * R * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
}

AltitudeFusion::Outcome AltitudeFusion::gated_update(const Row& H, double z, double R,
                                                     int sensor) {
  double r, S;
  residual(H, z, R, &r, &S);
  const double sd = std::sqrt(S);
  // Sec. 4.3: a very large residual gets K* = 0 (unless this sensor was refused too long).
  if (std::abs(r) > p_.reject_sigma * sd && rejects_[sensor] < p_.reject_limit) {
    ++rejects_[sensor];
    return Outcome::kRejectedOutlier;
  }
  rejects_[sensor] = 0;
  // Eq. 27: K* = K if |r| <= 2 sqrt(P~), else n K.
  const bool gated = std::abs(r) > p_.gate_sigma * sd;
  apply(H, r, R, gated ? p_.gate_factor_n : 1.0);
  update_set();
  return gated ? Outcome::kGated : Outcome::kAccepted;
}

AltitudeFusion::Outcome AltitudeFusion::update_baro(const BaroSample& s) {
  if (!age_ok(s.t_s)) return Outcome::kRejectedStale;
  if (!(s.pressure_pa > 0) || !std::isfinite(s.pressure_pa)) return Outcome::kRejectedRange;
  // Eq. 15 only: near the surface the downwash corrupts the baro (seed 004 sec. 4.2); unless
  // the ultrasonic that replaces it has been silent for baro_fallback_s. Over a moving
  // surface the ultrasonic does not anchor the height: the barometer stays.
  if (low_set_ && !(p_.moving_surface_rw_mps > 0.0)) {
    if (!(p_.baro_fallback_s > 0) || t_s_ - us_trusted_t_s_ <= p_.baro_fallback_s) {
      return Outcome::kRejectedSet;
    }
    ++baro_fallbacks_;
  }
  const double h_q = isa_altitude_m(s.pressure_pa) - p_.baro_origin_msl_m;  // eq. 8
  return gated_update(row({{kZ, 1.0}, {kBaroBias, 1.0}}, t_s_ - s.t_s), h_q,
                      p_.baro_std_m * p_.baro_std_m, 0);
}

AltitudeFusion::Outcome AltitudeFusion::update_gps(const GpsSample& s) {
  if (!age_ok(s.t_s)) return Outcome::kRejectedStale;
  if (!s.valid || !std::isfinite(s.p_W_m.z())) return Outcome::kRejectedRange;
  return gated_update(row({{kZ, 1.0}, {kGpsErr, 1.0}}, t_s_ - s.t_s), s.p_W_m.z(),
                      p_.gps_white_std_m * p_.gps_white_std_m, 1);
}

AltitudeFusion::Outcome AltitudeFusion::update_vision(double t_s, double h_plane_m,
                                                      double std_m) {
  if (!age_ok(t_s)) return Outcome::kRejectedStale;
  if (!std::isfinite(h_plane_m) || h_plane_m <= 0) return Outcome::kRejectedRange;
  const double sd = std_m > 0 && std::isfinite(std_m) ? std_m : p_.vision_std_m;
  return gated_update(row({{kZ, 1.0}, {kPlane, -1.0}}, t_s_ - t_s), h_plane_m, sd * sd, 2);
}

void AltitudeFusion::rereference_surface(double h_mean_m, double var_m2) {
  // New surface s' = z - h: Cov(s', x_j) = Cov(z, x_j), Var(s') = P_zz + var(h).
  x_[kSurface] = x_[kZ] - h_mean_m;
  P_.row(kSurface) = P_.row(kZ);
  P_.col(kSurface) = P_.col(kZ);
  P_(kSurface, kSurface) = P_(kZ, kZ) + var_m2;
}

bool AltitudeFusion::collect_step(double h_now_m, double* mean_m, double* var_m2) {
  if (step_n_ > 0 && std::abs(h_now_m - step_buf_[step_n_ - 1]) > p_.step_agree_m) step_n_ = 0;
  step_buf_[step_n_++] = h_now_m;
  if (step_n_ < p_.step_count) return false;
  double mean = 0.0;
  for (int i = 0; i < step_n_; ++i) mean += step_buf_[i];
  mean /= step_n_;
  double spread2 = 0.0;
  for (int i = 0; i < step_n_; ++i) spread2 += (step_buf_[i] - mean) * (step_buf_[i] - mean);
  *mean_m = mean;
  *var_m2 = p_.ultrasonic_std_m * p_.ultrasonic_std_m / step_n_ + spread2 / step_n_;
  step_n_ = 0;
  return true;
}

bool AltitudeFusion::collect_height_reset(double h_now_m, double* mean_m, double* var_m2) {
  if (p_.height_reset_count <= 0) return false;
  // Each reading's implied surface within step_agree_m of the previous one's (garbage does
  // not chain; a climb or descent does, the height's own motion taking the readings' change).
  AgreeingChain& c = reset_chain_;
  c.add(odo_z_ - h_now_m, t_s_, p_.step_agree_m);
  if (c.n < p_.height_reset_count) return false;
  *mean_m = odo_z_ - c.mean();
  *var_m2 = p_.ultrasonic_std_m * p_.ultrasonic_std_m / c.n + c.spread2();
  c.clear();
  return true;
}

// z' = s + h; the barometer (z + b) and the GPS (z + e_g) keep predicting what they did, so
// b' = b + z - s - h and e_g' = e_g + z - s - h; every other state unchanged. As a linear map
// x' = A x + B h with h ~ (h_mean, var): P' = A P A^T + B var B^T.
void AltitudeFusion::reset_height(double h_mean_m, double var_m2) {
  Mat A = Mat::Identity();
  Vec B = Vec::Zero();
  A(kZ, kZ) = 0.0;
  A(kZ, kSurface) = 1.0;
  B(kZ) = 1.0;
  for (int k : {kBaroBias, kGpsErr}) {
    A(k, kZ) += 1.0;
    A(k, kSurface) -= 1.0;
    B(k) = -1.0;
  }
  x_ = A * x_ + B * h_mean_m;
  P_ = A * P_ * A.transpose() + B * var_m2 * B.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
  ++height_resets_;
}

AltitudeFusion::Outcome AltitudeFusion::update_ultrasonic(const UltrasonicSample& s) {
  const Outcome o = fuse_ultrasonic(s);
  // A reading the filter used (or a step / reset it confirmed) is trusted (baro_fallback_s).
  if (o == Outcome::kAccepted || o == Outcome::kGated || o == Outcome::kSurfaceStep ||
      o == Outcome::kHeightReset) {
    us_trusted_t_s_ = t_s_;
  }
  return o;
}

AltitudeFusion::Outcome AltitudeFusion::fuse_ultrasonic(const UltrasonicSample& s) {
  if (!age_ok(s.t_s)) return Outcome::kRejectedStale;
  // Eq. 12: outside the valid range the reading is unbounded garbage.
  if (!std::isfinite(s.range_m) || s.range_m < p_.ultrasonic_min_m ||
      s.range_m > p_.ultrasonic_max_m) {
    step_n_ = 0;
    reset_chain_.clear();
    clear_chain_.clear();
    us_suspect_ = true;
    us_run_ = 0;
    return Outcome::kRejectedRange;
  }
  const double age = std::max(0.0, t_s_ - s.t_s);
  const double h_c = s.range_m * cos_tilt_;  // slant range to vertical height
  const double h_now = h_c + x_[kVz] * age;  // compensated to now by the predicted motion
  // The clearance chain, whatever the reading means for the surface state below.
  clear_chain_.add(odo_z_ - h_now, s.t_s, p_.step_agree_m);
  double mean, var;
  // A reading that implies a step beyond surface_step_max_m: garbage, unless enough of them
  // agree (then the height was wrong: height_reset_count).
  const auto impossible_step = [&](Outcome otherwise) {
    step_n_ = 0;
    if (!collect_height_reset(h_now, &mean, &var)) return otherwise;
    reset_height(mean, var);
    set_low(true);
    us_suspect_ = false;
    us_run_ = 0;
    return Outcome::kHeightReset;
  };
  if (!low_set_) {
    // Eq. 15 set in force: the reading is only a candidate for acquiring the surface below
    // (coming down into range). step_count agreeing in-range readings that imply a plausible
    // surface switch to the eq. 17 set and re-reference s (s was not observed up there).
    const double implied_jump = std::abs((x_[kZ] - h_now) - x_[kSurface]);
    if (implied_jump > p_.surface_step_max_m) return impossible_step(Outcome::kRejectedSet);
    reset_chain_.clear();
    if (!collect_step(h_now, &mean, &var)) return Outcome::kRejectedSet;
    rereference_surface(mean, var);
    set_low(true);
    us_suspect_ = false;
    us_run_ = 0;
    return Outcome::kSurfaceStep;
  }
  const double R = p_.ultrasonic_std_m * p_.ultrasonic_std_m;
  const Row H = row({{kZ, 1.0}, {kSurface, -1.0}}, age);
  double r, S;
  residual(H, h_c, R, &r, &S);
  if (std::abs(r) <= p_.gate_sigma * std::sqrt(S)) {
    reset_chain_.clear();
    step_n_ = 0;
    // After garbage, a reading that happens to fall inside the gate is not trusted until
    // step_count consecutive readings pass it (the sensor is back on the surface).
    if (us_suspect_ && ++us_run_ < p_.step_count) return Outcome::kStepPending;
    us_suspect_ = false;
    us_run_ = 0;
    apply(H, r, R, 1.0);
    update_set();
    return Outcome::kAccepted;
  }
  if (std::abs(r) < p_.step_min_m) {
    step_n_ = 0;
    reset_chain_.clear();
    if (us_suspect_) {  // still re-confirming after garbage: hold it
      us_run_ = 0;
      return Outcome::kStepPending;
    }
    apply(H, r, R, p_.gate_factor_n);  // eq. 27
    update_set();
    return Outcome::kGated;
  }
  // Large residual: a surface step (platform edge) or garbage. Not applied; step_count
  // consecutive agreeing values re-reference the surface instead of moving z.
  us_suspect_ = true;
  us_run_ = 0;
  if (std::abs(r) > p_.surface_step_max_m) return impossible_step(Outcome::kStepPending);
  reset_chain_.clear();
  if (!collect_step(h_now, &mean, &var)) return Outcome::kStepPending;
  rereference_surface(mean, var);
  us_suspect_ = false;
  update_set();
  return Outcome::kSurfaceStep;
}

AltitudeEstimate AltitudeFusion::estimate() const {
  AltitudeEstimate e;
  e.t_s = t_s_;
  e.valid = true;
  e.z_W_m = x_[kZ];
  e.vz_W_mps = x_[kVz];
  e.h_surface_m = x_[kZ] - x_[kSurface];
  e.baro_bias_m = x_[kBaroBias];
  e.var_m2 = P_(kZ, kZ);
  if (p_.clearance_count > 0 && clear_chain_.n >= p_.clearance_count &&
      t_s_ - clear_chain_.last_t_s <= p_.max_sample_age_s) {
    e.clearance_m = odo_z_ - clear_chain_.last;
  }
  return e;
}

}  // namespace lander
