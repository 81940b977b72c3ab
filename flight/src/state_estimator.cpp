// Our estimator's filters without vision (components.h): the sample screen first, then the
// navigation filter and the altitude fusion (seed 004).
#include <cmath>

#include "lander/estimator/altitude_vision.h"
#include "lander/flight/components.h"

namespace lander::flight {

StateEstimator::StateEstimator(const EstimatorParams& p)
    : p_(p), nav_(p.navigation), fusion_(p.altitude), screen_(p.sample_limits) {}

void StateEstimator::on_baro(const BaroSample& b) {
  if (!screen_.accept(b)) return;
  if (!fusion_started_) {
    // In the air at start: the first reading fixes height + baro bias, not their split.
    fusion_.reset_from_baro(b);
    fusion_started_ = true;
  }
  fusion_.update_baro(b);
}

void StateEstimator::on_gps(const GpsSample& g) {
  if (!screen_.accept(g)) return;
  nav_.add_gps(g);
  if (fusion_started_) fusion_.update_gps(g);
}

void StateEstimator::on_ultrasonic(const UltrasonicSample& u) {
  if (!screen_.accept(u)) return;
  if (fusion_started_) fusion_.update_ultrasonic(u);
}

void StateEstimator::on_mag(const MagSample& m) {
  if (screen_.accept(m)) nav_.add_mag(m);
}

std::optional<ImuSample> StateEstimator::on_imu(const ImuSample& raw) {
  // A rejected sample is replaced by the last good one (zero-order hold).
  const std::optional<ImuSample> screened = screen_.imu(raw);
  if (!screened) return std::nullopt;
  nav_.add_imu(*screened);
  if (fusion_started_) fusion_.predict(*screened, nav_.state().q_WB, p_.navigation.gravity_mps2);
  return screened;
}

bool StateEstimator::on_vision(const PlatformObservation& obs, double h_plane_m) {
  if (!screen_.accept(obs)) return false;
  if (fusion_started_ && std::isfinite(h_plane_m)) fusion_.update_vision(obs.t_s, h_plane_m);
  return true;
}

// The GPS-only vertical channel follows the receiver's slowly varying height error (metres
// with a degraded GPS: a hold on it drifts with the error); the fusion's height is anchored by
// the barometer, the ultrasonic and vision.
NavState StateEstimator::nav_state() const {
  if (p_.navigation.height_from_altitude_fusion && fusion_started_) return with_altitude(nav_.state(), fusion_.estimate());
  return nav_.state();
}

}  // namespace lander::flight
