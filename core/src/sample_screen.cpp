#include "lander/core/sample_screen.h"

#include <cmath>

namespace lander {

void SampleLimits::validate() const {
  check_fields(*this);
  require(max_pressure_pa > min_pressure_pa, "max_pressure_pa", "must be > min_pressure_pa");
}

bool plausible_observation(const PlatformObservation& obs, double max_range_m) {
  if (!std::isfinite(obs.t_s)) return false;
  if (!obs.detected) return true;
  const Eigen::Matrix3d R = obs.X_CP.linear();
  const Eigen::Vector3d p = obs.X_CP.translation();
  if (!R.allFinite() || !p.allFinite() || !obs.cov.allFinite()) return false;
  // A rotation: orthonormal (to far looser than any solver's rounding) and right-handed.
  constexpr double kOrthonormalTol = 1e-3;
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kOrthonormalTol ||
      R.determinant() < 0) {
    return false;
  }
  return p.z() > 0 && p.norm() <= max_range_m;
}

SampleScreen::SampleScreen(const SampleLimits& limits) : p_(limits) { p_.validate(); }

std::optional<ImuSample> SampleScreen::imu(const ImuSample& s) {
  const bool ok = s.gyro_B_radps.allFinite() && s.accel_B_mps2.allFinite() &&
                  s.gyro_B_radps.cwiseAbs().maxCoeff() <= p_.max_gyro_radps &&
                  s.accel_B_mps2.cwiseAbs().maxCoeff() <= p_.max_accel_mps2;
  if (!std::isfinite(s.t_s)) {
    ++rejected_.imu;
    return std::nullopt;
  }
  if (ok) {
    last_imu_ = s;
    return s;
  }
  ++rejected_.imu;
  if (!last_imu_) return std::nullopt;
  ImuSample held = *last_imu_;
  held.t_s = s.t_s;
  return held;
}

bool SampleScreen::accept(const BaroSample& s) {
  const bool ok = std::isfinite(s.t_s) && std::isfinite(s.pressure_pa) &&
                  s.pressure_pa >= p_.min_pressure_pa && s.pressure_pa <= p_.max_pressure_pa;
  if (!ok) ++rejected_.baro;
  return ok;
}

bool SampleScreen::accept(const GpsSample& s) {
  bool ok = std::isfinite(s.t_s);
  if (ok && s.valid) {
    ok = s.p_W_m.allFinite() && s.v_W_mps.allFinite() &&
         s.p_W_m.norm() <= p_.max_gps_distance_m && s.v_W_mps.norm() <= p_.max_gps_speed_mps;
  }
  if (!ok) ++rejected_.gps;
  return ok;
}

bool SampleScreen::accept(const UltrasonicSample& s) {
  const bool ok = std::isfinite(s.t_s) && std::isfinite(s.range_m) && s.range_m >= 0;
  if (!ok) ++rejected_.ultrasonic;
  return ok;
}

bool SampleScreen::accept(const MagSample& s) {
  const bool ok = std::isfinite(s.t_s) && s.field_B_uT.allFinite() &&
                  s.field_B_uT.norm() <= p_.max_mag_field_uT;
  if (!ok) ++rejected_.magnetometer;
  return ok;
}

bool SampleScreen::accept(const PlatformObservation& obs) {
  const bool ok = plausible_observation(obs, p_.max_vision_range_m);
  if (!ok) ++rejected_.vision;
  return ok;
}

}  // namespace lander
