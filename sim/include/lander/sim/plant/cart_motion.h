// Scripted motion of the cart: a path (straight line or circular arc) travelled with a speed
// profile (constant, or stop-and-go as a person pulling a cart). Closed form in time, so the
// reference and its derivatives are exact at any instant.
#pragma once

#include <string>

#include <Eigen/Core>

#include "lander/core/params_io.h"
#include "lander/sim/plant/deck_motion.h"
#include "lander/sim/plant/route.h"

namespace lander::sim {

struct CartMotionParams {
  std::string path{"straight"};           ///< static | straight | arc | route (the centre
                                          ///< line of world.route, from route_start_m on;
                                          ///< start_m and heading_deg are then unused)
  std::string speed_profile{"constant"};  ///< constant | stop_and_go
  Eigen::Vector2d start_m{0.0, 0.0};      ///< platform centre at t = 0, in W (m)
  double heading_rad{0.0};                ///< initial heading from W x (rad); YAML heading_deg
  double speed_mps{0.5};                  ///< cruise speed (m/s)
  double turn_radius_m{10.0};             ///< arc radius (m); > 0 turns left, < 0 right
  double accel_mps2{0.6};                 ///< stop_and_go acceleration and braking (m/s^2)
  double go_s{4.0};                       ///< stop_and_go cruise time per cycle (s)
  double stop_s{2.0};                     ///< stop_and_go standstill time per cycle (s)
  double start_delay_s{0.0};              ///< time before the cart starts (s)
  double route_start_m{0.0};              ///< path route: arc length of the start (m); the
                                          ///< cart stops at the route's end
  double platform_height_m{0.80};         ///< true height of the platform's top above the
                                          ///< ground (m); models/cart.xml has 0.80 m
  DeckSeaParams deck_motion;           ///< heave, roll and pitch of the platform (a boat's
                                          ///< deck): models/cart_deck.xml
  void validate() const;
};

template <class V>
void visit_fields(V& v, CartMotionParams& p) {
  v("path", p.path, range::any, "", "static | straight | arc | route");
  v("speed_profile", p.speed_profile, range::any, "", "constant | stop_and_go");
  v("start_m", p.start_m, range::any, "m", "platform centre at t");
  v("heading_deg", p.heading_rad, range::any, "deg", "initial heading from W x", M_PI / 180.0);
  v("speed_mps", p.speed_mps, range::closed(0, 15).because("a car at 50 km/h, the fastest landing deck reported"), "m/s",
    "cruise speed");
  v("turn_radius_m", p.turn_radius_m, range::any, "m", "arc radius; > 0 turns left");
  v("accel_mps2", p.accel_mps2, range::open_closed(0, 5), "m/s^2",
    "stop_and_go acceleration and braking");
  v("go_s", p.go_s, range::non_negative, "s", "stop_and_go cruise time per cycle");
  v("stop_s", p.stop_s, range::non_negative, "s", "stop_and_go standstill time per cycle");
  v("start_delay_s", p.start_delay_s, range::non_negative, "s", "time before the cart starts");
  v("route_start_m", p.route_start_m, range::non_negative, "m",
    "path route: arc length of the start");
  v("platform_height_m", p.platform_height_m,
    range::closed(0.4, 3).because("the platform sits on the cart's posts, or a boat's deck"), "m",
    "true height of the platform's top above the ground");
  v.nested("deck_motion", p.deck_motion);
}

// Cart reference: q = (x, y, yaw) of the platform centre in W and its first two derivatives.
struct CartReference {
  Eigen::Vector3d q{Eigen::Vector3d::Zero()};
  Eigen::Vector3d qd{Eigen::Vector3d::Zero()};
  Eigen::Vector3d qdd{Eigen::Vector3d::Zero()};
};

// `route` is the painted route's centre line, used by path "route" (required then).
CartReference cart_reference(const CartMotionParams& p, double t_s,
                             const RouteGeometry* route = nullptr);

}  // namespace lander::sim
