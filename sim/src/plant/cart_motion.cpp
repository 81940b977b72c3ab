#include "lander/sim/plant/cart_motion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lander::sim {

void CartMotionParams::validate() const {
  check_fields(*this);
  require(path == "static" || path == "straight" || path == "arc" || path == "route", "path",
          "must be static, straight, arc or route (got '" + path + "')");
  require(speed_profile == "constant" || speed_profile == "stop_and_go", "speed_profile",
          "must be constant or stop_and_go (got '" + speed_profile + "')");
  require(path != "arc" || std::abs(turn_radius_m) >= 2, "turn_radius_m",
          "|radius| must be >= 2 m");
  validate_nested("deck_motion", deck_motion);
  if (deck_motion.present()) {
    const double low = platform_height_m - deck_motion.peak_heave_m() -
                       kPlatformHalfSide_m * std::sin(std::min(deck_motion.peak_tilt_rad(), M_PI / 2));
    require(low >= kDeckGroundClearance_m, "platform_height_m",
            "must keep the moving deck above the ground: its edge would come " + std::to_string(low) +
                " m from it at the deck's peaks (heave " + std::to_string(deck_motion.peak_heave_m()) +
                " m, tilt " + std::to_string(deck_motion.peak_tilt_rad() * 180.0 / M_PI) +
                " deg); raise it to at least " +
                std::to_string(platform_height_m - low + kDeckGroundClearance_m) + " m");
  }
}

namespace {

// Distance travelled s(t) and its derivatives for the speed profile.
void speed_profile(const CartMotionParams& p, double t, double& s, double& sd, double& sdd) {
  s = sd = sdd = 0.0;
  if (p.path == "static" || t < p.start_delay_s) return;  // constant: moving from t = 0
  t -= p.start_delay_s;
  const double v = p.speed_mps;
  if (p.speed_profile == "constant") {
    s = v * t;
    sd = v;
    return;
  }
  // Stop and go: accelerate (ta), cruise (go_s), brake (ta), stand (stop_s), repeat.
  const double a = p.accel_mps2, ta = v / a;
  const double period = 2 * ta + p.go_s + p.stop_s;
  const double per_cycle = v * ta + v * p.go_s;  // distance of one cycle
  const double n = std::floor(t / period);
  double tc = t - n * period;
  s = n * per_cycle;
  if (tc < ta) {
    s += 0.5 * a * tc * tc;
    sd = a * tc;
    sdd = a;
  } else if ((tc -= ta) < p.go_s) {
    s += 0.5 * v * ta + v * tc;
    sd = v;
  } else if ((tc -= p.go_s) < ta) {
    s += 0.5 * v * ta + v * p.go_s + v * tc - 0.5 * a * tc * tc;
    sd = v - a * tc;
    sdd = -a;
  } else {
    s += per_cycle;
  }
}

}  // namespace

CartReference cart_reference(const CartMotionParams& p, double t_s, const RouteGeometry* route) {
  double s, sd, sdd;
  speed_profile(p, t_s, s, sd, sdd);
  // The point at arc length s: position, heading h and curvature k (1/m) of the path.
  Eigen::Vector2d pos;
  double h = 0.0, k = 0.0;
  if (p.path == "route") {
    if (route == nullptr || route->empty()) throw std::logic_error("cart path 'route' without a route");
    s += p.route_start_m;
    if (s >= route->length()) {  // the end of the route: the cart stops there
      s = route->length();
      sd = sdd = 0.0;
    }
    const RoutePoint rp = route->at(s);
    pos = rp.p_m;
    h = rp.heading_rad;
    k = rp.curvature;
  } else {
    k = p.path == "arc" ? 1.0 / p.turn_radius_m : 0.0;
    const double h0 = p.heading_rad;
    h = h0 + k * s;
    if (k == 0.0) {
      pos << p.start_m.x() + s * std::cos(h0), p.start_m.y() + s * std::sin(h0);
    } else {
      pos << p.start_m.x() + (std::sin(h) - std::sin(h0)) / k, p.start_m.y() - (std::cos(h) - std::cos(h0)) / k;
    }
  }
  CartReference r;
  r.q << pos, h;
  const Eigen::Vector2d t_hat(std::cos(h), std::sin(h)), n_hat(-std::sin(h), std::cos(h));
  r.qd << sd * t_hat, k * sd;
  r.qdd << sdd * t_hat + sd * sd * k * n_hat, k * sdd;
  return r;
}

}  // namespace lander::sim
