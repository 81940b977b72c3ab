// Limits from the vehicle model (see vehicle_limits.h).
#include "lander/controller/vehicle_limits.h"

#include <algorithm>
#include <cmath>

namespace lander::ctl {
namespace {
constexpr double kDegToRad = M_PI / 180.0;
constexpr int kRotors = 6;

// The speed v >= 0 at which drag_linear v + drag_quadratic v^2 = force (the positive root).
double speed_at_drag(const VehicleParams& v, double force_N) {
  const double a = v.drag_quadratic_Ns2pm2;
  const double b = v.drag_linear_Nspm;
  if (a <= 0.0 && b <= 0.0) return std::numeric_limits<double>::infinity();
  if (a <= 0.0) return force_N / b;
  return (-b + std::sqrt(b * b + 4.0 * a * force_N)) / (2.0 * a);
}
}  // namespace

std::string VehicleLimits::speed_source() const {
  return speed_from_model ? "the vehicle model (drag at the tilt limit)" : "cascade.max_vel_xy_mps";
}

double drag_force_N(const VehicleParams& v, double airspeed_mps) {
  const double s = std::abs(airspeed_mps);
  return v.drag_linear_Nspm * s + v.drag_quadratic_Ns2pm2 * s * s;
}

VehicleLimits derive_limits(const VehicleParams& v, const CascadeParams& c) {
  VehicleLimits L;
  const double weight_N = v.mass_kg * v.gravity_mps2;
  const double full_thrust_N = kRotors * v.k_thrust * v.w_max_radps * v.w_max_radps;
  L.hover_thrust_share = weight_N / full_thrust_N;
  // Holding height at tilt t needs thrust m g / cos t; keep kThrustReserve for control.
  const double usable = (1.0 - kThrustReserve) * full_thrust_N;
  L.thrust_tilt_deg = usable > weight_N ? std::acos(weight_N / usable) / kDegToRad : 0.0;
  L.tilt_deg = std::min(c.max_tilt_deg, L.thrust_tilt_deg);
  L.max_accel_xy_mps2 = v.gravity_mps2 * std::tan(L.tilt_deg * kDegToRad);
  L.drag_speed_mps = speed_at_drag(v, c.max_vel_drag_share * v.mass_kg * L.max_accel_xy_mps2);
  L.speed_from_model = c.max_vel_xy_mps <= 0.0;
  L.max_speed_xy_mps = L.speed_from_model ? L.drag_speed_mps : c.max_vel_xy_mps;
  return L;
}

}  // namespace lander::ctl
