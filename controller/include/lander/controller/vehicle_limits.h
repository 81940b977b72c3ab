// Speed and acceleration limits derived from the flight software's own vehicle model (issue
// 56): the thrust margin, the tilt limit and the airframe's drag, not figures tuned for a
// walking cart. The cascade takes its absolute horizontal speed limit from here when
// `cascade.max_vel_xy_mps` is 0 (the default); the landing modes compare the platform's
// estimated speed with it and say in the decision log when a platform is out of reach.
#pragma once

#include <string>

#include "lander/controller/params.h"

namespace lander::ctl {

struct VehicleLimits {
  double hover_thrust_share{0.0};  ///< m g over the six rotors' full thrust (dimensionless)
  double thrust_tilt_deg{0.0};     ///< largest tilt at which the thrust still holds height with
                                   ///< kThrustReserve of full thrust kept for control (deg)
  double tilt_deg{0.0};            ///< min(cascade.max_tilt_deg, thrust_tilt_deg) (deg)
  double max_accel_xy_mps2{0.0};   ///< horizontal acceleration at tilt_deg holding height (m/s^2)
  double drag_speed_mps{0.0};      ///< airspeed at which the airframe's drag takes
                                   ///< cascade.max_vel_drag_share of max_accel_xy (m/s)
  double max_speed_xy_mps{0.0};    ///< the horizontal speed limit the cascade applies (m/s)
  bool speed_from_model{false};    ///< max_speed_xy_mps is drag_speed_mps (max_vel_xy_mps 0)
  /// Where max_speed_xy_mps comes from, for decision reasons: "cascade.max_vel_xy_mps" or
  /// "the vehicle model (drag at the tilt limit)".
  std::string speed_source() const;
};

// Share of the rotors' full thrust kept for attitude control when the tilt limit is derived.
constexpr double kThrustReserve = 0.1;

// The limits of a vehicle (VehicleParams: mass, rotors, drag) under a cascade's tilt limit and
// speed keys. Pure; throws nothing for validated parameters.
VehicleLimits derive_limits(const VehicleParams& vehicle, const CascadeParams& cascade);

// Horizontal drag force magnitude of the airframe at airspeed v (N), the flight software's
// model: drag_linear v + drag_quadratic v^2.
double drag_force_N(const VehicleParams& vehicle, double airspeed_mps);

}  // namespace lander::ctl
