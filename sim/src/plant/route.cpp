#include "lander/sim/plant/route.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lander::sim {

namespace {
double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }
Eigen::Vector2d unit_at(double phi) { return {std::cos(phi), std::sin(phi)}; }
}  // namespace

void RouteParams::validate() const {
  check_fields(*this);
  require(rgb.minCoeff() >= 0 && rgb.maxCoeff() <= 1, "rgb", "must be in [0, 1]");
  for (std::size_t i = 0; i < gaps.size(); ++i) validate_item("gaps", i, gaps[i]);
  for (std::size_t i = 0; i < paint.size(); ++i) validate_item("paint", i, paint[i]);
  if (waypoints.empty()) return;
  require(waypoints.size() >= 2, "waypoints", "a route needs at least 2 waypoints");
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    validate_item("waypoints", i, waypoints[i]);
    require(waypoints[i].p_m.allFinite() && waypoints[i].p_m.cwiseAbs().maxCoeff() < 95,
            "waypoints[" + std::to_string(i) + "].p_m", "must lie within 95 m of the origin (the ground plane)");
    if (i > 0) {
      require((waypoints[i].p_m - waypoints[i - 1].p_m).norm() > 0.05,
              "waypoints[" + std::to_string(i) + "].p_m", "must be more than 0.05 m from the previous waypoint");
    }
    require(waypoints[i].corner_radius_m <= 50, "waypoints[" + std::to_string(i) + "].corner_radius_m",
            "must be <= 50 m");
  }
  require(paint.size() <= kPaintPlaceholders, "paint",
          "at most " + std::to_string(kPaintPlaceholders) + " patches (the world model's placeholders)");
  const RouteGeometry g(*this);
  require(g.paint_rects().size() <= kRouteBoxPlaceholders, "waypoints",
          "the route needs " + std::to_string(g.paint_rects().size()) + " paint pieces, the world model has " +
              std::to_string(kRouteBoxPlaceholders) + " (fewer corners, arcs or gaps)");
  require(g.paint_discs().size() <= kRouteDiscPlaceholders, "waypoints",
          "at most " + std::to_string(kRouteDiscPlaceholders) + " sharp corners");
}

RouteGeometry::RouteGeometry(const RouteParams& p) : gaps_(p.gaps) {
  const std::vector<RouteWaypoint>& w = p.waypoints;
  if (w.size() < 2) return;
  Eigen::Vector2d cur = w[0].p_m;  // where the next line starts
  auto add_line = [&](const Eigen::Vector2d& to) {
    if ((to - cur).norm() < 1e-9) return;
    Piece pc;
    pc.a_m = cur;
    pc.b_m = to;
    pc.len_m = (to - cur).norm();
    pieces_.push_back(pc);
    cur = to;
  };
  for (std::size_t i = 1; i + 1 < w.size(); ++i) {
    const Eigen::Vector2d P = w[i].p_m;
    const Eigen::Vector2d d0 = (P - w[i - 1].p_m).normalized(), d1 = (w[i + 1].p_m - P).normalized();
    const double theta = std::atan2(cross2(d0, d1), d0.dot(d1));  // signed turn (rad)
    double r = w[i].corner_radius_m >= 0 ? w[i].corner_radius_m : p.corner_radius_m;
    if (std::abs(theta) < 1e-6) continue;  // straight on
    if (r <= 0 || std::abs(theta) > M_PI - 1e-3) {
      add_line(P);
      sharp_.push_back(P);
      continue;
    }
    // The fillet's tangent points may use at most the free part of each adjacent segment
    // (half of the next one, all of what is left of the previous one).
    const double t_max = std::min((P - cur).norm(), 0.5 * (w[i + 1].p_m - P).norm());
    double t = r * std::tan(0.5 * std::abs(theta));
    if (t > t_max) {
      t = t_max;
      r = t / std::tan(0.5 * std::abs(theta));
    }
    const Eigen::Vector2d T0 = P - d0 * t, T1 = P + d1 * t;
    add_line(T0);
    const double sgn = theta > 0 ? 1.0 : -1.0;
    const Eigen::Vector2d n0(-d0.y(), d0.x());
    Piece arc;
    arc.arc = true;
    arc.centre_m = T0 + sgn * r * n0;
    arc.radius_m = r;
    arc.phi0_rad = std::atan2(T0.y() - arc.centre_m.y(), T0.x() - arc.centre_m.x());
    arc.sweep_rad = theta;
    arc.len_m = r * std::abs(theta);
    pieces_.push_back(arc);
    cur = T1;
  }
  add_line(w.back().p_m);
  double s = 0;
  for (Piece& pc : pieces_) {
    pc.s0_m = s;
    s += pc.len_m;
  }
  length_ = s;
}

RoutePoint RouteGeometry::piece_at(const Piece& pc, double u) const {
  RoutePoint r;
  if (!pc.arc) {
    const Eigen::Vector2d d = (pc.b_m - pc.a_m) / pc.len_m;
    r.p_m = pc.a_m + d * u;
    r.heading_rad = std::atan2(d.y(), d.x());
    return r;
  }
  const double sgn = pc.sweep_rad > 0 ? 1.0 : -1.0;
  const double phi = pc.phi0_rad + sgn * u / pc.radius_m;
  r.p_m = pc.centre_m + pc.radius_m * unit_at(phi);
  r.heading_rad = std::remainder(phi + sgn * M_PI / 2, 2 * M_PI);
  r.curvature = sgn / pc.radius_m;
  return r;
}

RoutePoint RouteGeometry::at(double s) const {
  if (pieces_.empty()) return {};
  s = std::clamp(s, 0.0, length_);
  for (const Piece& pc : pieces_) {
    if (s <= pc.s0_m + pc.len_m) return piece_at(pc, s - pc.s0_m);
  }
  return piece_at(pieces_.back(), pieces_.back().len_m);
}

double RouteGeometry::distance(const Eigen::Vector2d& p, double* s_out) const {
  double best = std::numeric_limits<double>::infinity(), best_s = 0;
  for (const Piece& pc : pieces_) {
    std::vector<double> us{0.0, pc.len_m};  // the ends, and the foot of the perpendicular
    if (!pc.arc) {
      const Eigen::Vector2d d = (pc.b_m - pc.a_m) / pc.len_m;
      us.push_back(std::clamp((p - pc.a_m).dot(d), 0.0, pc.len_m));
    } else {
      const Eigen::Vector2d q = p - pc.centre_m;
      const double sgn = pc.sweep_rad > 0 ? 1.0 : -1.0;
      // Angle from the start along the sweep's sense, in [0, 2 pi).
      double a = std::fmod(sgn * (std::atan2(q.y(), q.x()) - pc.phi0_rad), 2 * M_PI);
      if (a < 0) a += 2 * M_PI;
      if (a <= std::abs(pc.sweep_rad)) us.push_back(pc.radius_m * a);
    }
    for (double u : us) {
      const double dist = (piece_at(pc, u).p_m - p).norm();
      if (dist < best) {
        best = dist;
        best_s = pc.s0_m + u;
      }
    }
  }
  if (s_out) *s_out = best_s;
  return best;
}

bool RouteGeometry::painted(double s) const {
  for (const RouteGap& g : gaps_) {
    if (s > g.from_m && s < g.to_m) return false;
  }
  return true;
}

std::vector<RouteGeometry::Rect> RouteGeometry::paint_rects(double max_chord_deg) const {
  std::vector<Rect> out;
  for (const Piece& pc : pieces_) {
    // Painted intervals of this piece in its own arc length.
    std::vector<std::pair<double, double>> iv{{0.0, pc.len_m}};
    for (const RouteGap& g : gaps_) {
      std::vector<std::pair<double, double>> next;
      for (auto [a, b] : iv) {
        const double ga = g.from_m - pc.s0_m, gb = g.to_m - pc.s0_m;
        if (gb <= a || ga >= b) {
          next.push_back({a, b});
          continue;
        }
        if (ga > a) next.push_back({a, ga});
        if (gb < b) next.push_back({gb, b});
      }
      iv = next;
    }
    for (auto [a, b] : iv) {
      if (b - a < 1e-6) continue;
      const double step = pc.arc ? pc.radius_m * max_chord_deg * M_PI / 180.0 : b - a;
      const int n = std::max(1, static_cast<int>(std::ceil((b - a) / step)));
      for (int k = 0; k < n; ++k) {
        const double u0 = a + (b - a) * k / n, u1 = a + (b - a) * (k + 1) / n;
        const RoutePoint m = piece_at(pc, 0.5 * (u0 + u1));
        // Chords of an arc overlap a little so the outer edge has no notches.
        const double overlap = pc.arc ? 0.02 * (u1 - u0) + 0.002 : 0.0;
        out.push_back({m.p_m, m.heading_rad, u1 - u0 + overlap});
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector2d> RouteGeometry::paint_discs() const {
  std::vector<Eigen::Vector2d> out;
  for (const Eigen::Vector2d& v : sharp_) {
    double s = 0;
    distance(v, &s);
    if (painted(s)) out.push_back(v);
  }
  return out;
}

}  // namespace lander::sim
