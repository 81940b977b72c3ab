// A painted route on the ground (issue 14, seed 003): a polyline of waypoints whose corners
// are rounded with a radius (0 = a sharp corner), painted with a width and a colour, with
// optional worn gaps, plus paint of other colours as distractors. The world paints it with
// visual-only geoms (world.cpp); the cart can drive its centre line (cart.path: route); the
// recorder measures the vehicle's cross-track error against it. Truth only: the flight
// software sees the route only in the camera's frames.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "lander/core/params_io.h"

namespace lander::sim {

struct RouteWaypoint {
  Eigen::Vector2d p_m{0.0, 0.0};  ///< position on the ground, in W (m)
  double corner_radius_m{-1.0};   ///< radius the corner at this waypoint is rounded with (m);
                                  ///< < 0: the route's corner_radius_m; 0: sharp
  void validate() const {}
};

template <class V>
void visit_fields(V& v, RouteWaypoint& p) {
  v("p_m", p.p_m, range::any, "m", "position on the ground");
  v("corner_radius_m", p.corner_radius_m, range::any, "m",
    "radius the corner at this waypoint is rounded with");
}

// A stretch of the centre line where the paint is worn away: [from_m, to_m] of arc length.
struct RouteGap {
  double from_m{0.0};
  double to_m{0.0};
  void validate() const { require(to_m > from_m && from_m >= 0, "to_m", "needs 0 <= from_m < to_m"); }
};

template <class V>
void visit_fields(V& v, RouteGap& p) {
  v("from_m", p.from_m, range::any, "m", "");
  v("to_m", p.to_m, range::any, "m", "");
}

// A patch of paint of another colour (a distractor): a rectangle on the ground.
struct PaintPatch {
  Eigen::Vector2d centre_m{0.0, 0.0};  ///< centre in W (m)
  Eigen::Vector2d size_m{1.0, 0.2};    ///< length along its heading, width (m)
  double yaw_rad{0.0};                 ///< heading from W x (rad); YAML yaw_deg
  Eigen::Vector3d rgb{0.9, 0.8, 0.1};  ///< colour (0..1)
  void validate() const {
    require(size_m.minCoeff() > 0 && size_m.maxCoeff() <= 50, "size_m", "must be in (0, 50] m");
    require(rgb.minCoeff() >= 0 && rgb.maxCoeff() <= 1, "rgb", "must be in [0, 1]");
  }
};

template <class V>
void visit_fields(V& v, PaintPatch& p) {
  v("centre_m", p.centre_m, range::any, "m", "centre in W");
  v("size_m", p.size_m, range::any, "m", "length along its heading");
  v("yaw_deg", p.yaw_rad, range::any, "deg", "heading from W x", M_PI / 180.0);
  v("rgb", p.rgb, range::any, "", "colour");
}

// Placeholder geoms models/world_route.xml holds for the paint (world.cpp places them).
constexpr std::size_t kRouteBoxPlaceholders = 128;   // route_box_*: straight pieces, arc chords
constexpr std::size_t kRouteDiscPlaceholders = 16;   // route_disc_*: sharp corners
constexpr std::size_t kPaintPlaceholders = 16;       // paint_box_*: distractor patches

struct RouteParams {
  std::vector<RouteWaypoint> waypoints;  ///< empty: no route (at least 2 otherwise)
  double corner_radius_m{0.0};           ///< default corner radius (m), 0 = sharp corners
  double width_m{0.2};                   ///< paint width (m); the paper: 0.2 m
  Eigen::Vector3d rgb{0.85, 0.1, 0.1};   ///< paint colour (0..1); red by default
  std::vector<RouteGap> gaps;            ///< worn stretches
  std::vector<PaintPatch> paint;         ///< distractor paint of other colours
  bool present() const { return !waypoints.empty(); }
  void validate() const;
};

template <class V>
void visit_fields(V& v, RouteParams& p) {
  v.list("waypoints", p.waypoints);
  v("corner_radius_m", p.corner_radius_m, range::closed(0, 50), "m", "default corner radius");
  v("width_m", p.width_m, range::closed(0.02, 2.0), "m", "paint width");
  v("rgb", p.rgb, range::any, "", "paint colour");
  v.list("gaps", p.gaps);
  v.list("paint", p.paint);
}

// A point of the centre line.
struct RoutePoint {
  Eigen::Vector2d p_m{Eigen::Vector2d::Zero()};
  double heading_rad{0.0};   ///< direction of travel (rad from W x)
  double curvature{0.0};     ///< 1/m, > 0 turning left
};

// The centre line as lines and circular arcs (the rounded corners), by arc length.
class RouteGeometry {
 public:
  RouteGeometry() = default;  // no route
  explicit RouteGeometry(const RouteParams& p);
  bool empty() const { return pieces_.empty(); }
  double length() const { return length_; }
  // The point at arc length s (clamped to [0, length]).
  RoutePoint at(double s_m) const;
  // Distance of p to the centre line (m) and the arc length of its nearest point.
  double distance(const Eigen::Vector2d& p_m, double* s_m = nullptr) const;
  // The painted pieces: rectangles (centre, heading, length, width) covering the paint with
  // the gaps left out; arcs are cut into chords of at most max_chord_deg.
  struct Rect {
    Eigen::Vector2d centre_m;
    double heading_rad;
    double length_m;
  };
  std::vector<Rect> paint_rects(double max_chord_deg = 6.0) const;
  // Sharp corners (radius 0) whose vertex is painted: discs of the paint width fill them (the
  // route's ends stay square).
  std::vector<Eigen::Vector2d> paint_discs() const;

 private:
  struct Piece {
    bool arc{false};
    Eigen::Vector2d a_m{Eigen::Vector2d::Zero()}, b_m{Eigen::Vector2d::Zero()};  ///< line: a to b
    Eigen::Vector2d centre_m{Eigen::Vector2d::Zero()};  ///< arc: centre
    double radius_m{0.0}, phi0_rad{0.0}, sweep_rad{0.0};  ///< arc: start angle, signed sweep
    double s0_m{0.0}, len_m{0.0};
  };
  RoutePoint piece_at(const Piece& pc, double u_m) const;
  bool painted(double s_m) const;
  std::vector<Piece> pieces_;
  std::vector<Eigen::Vector2d> sharp_;
  std::vector<RouteGap> gaps_;
  double length_{0.0};
};

}  // namespace lander::sim
