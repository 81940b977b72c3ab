// The landing platform's target: single source of truth (models/target.yaml).
//
// Seven concentric ring sets (seed 000 section 1, Fig. 1): one at the platform centre and
// six on a regular hexagon around it; each set is a dark annulus between an inner and an
// outer circle, and its own inner/outer radius ratio makes its cross-ratio (seed 000
// eq. 9) unique. A globally unique binary code map (seed 001 section 2: every b x b window
// unique, Y = 2) fills a square inside the central ring's inner circle, so the camera still
// sees code cells when the rings no longer fit in view, down to touchdown.
//
// Platform frame P: origin at the centre of the central ring on the top surface, x and y in
// the surface, z out of it. Texture convention: texture pixel (u, v) (OpenCV, pixel centres
// at integers) covers P points x = (u + 0.5) / px_per_m - size_x / 2 and
// y = size_y / 2 - (v + 0.5) / px_per_m, i.e. row 0 is the +y edge, column 0 the -x edge.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "lander/core/params_io.h"

namespace lander {

struct RingSet {
  int id{0};                                             ///< identity, 0 = centre
  Eigen::Vector2d centre_P_m{Eigen::Vector2d::Zero()};   ///< centre in P (m)
  double outer_radius_m{0.2};                            ///< outer circle radius (m)
  double inner_radius_m{0.1};                            ///< inner circle radius (m)
  Eigen::Vector3d colour_rgb{0.0, 0.0, 0.0};             ///< annulus colour, 0..1

  double radius_ratio() const { return inner_radius_m / outer_radius_m; }
  // Cross-ratio Cr{o1, i1; i2, o2} (seed 000 eq. 9) of the four points where a line through
  // the centre meets the circles: o1 = -R, i1 = -r, i2 = r, o2 = R along the line.
  double cross_ratio() const;
  void validate() const;
};

template <class V>
void visit_fields(V& v, RingSet& p) {
  v("id", p.id, range::any, "", "identity, 0 = centre");
  v("centre_m", p.centre_P_m, range::any, "m", "centre in P");
  v("outer_radius_m", p.outer_radius_m, range::positive, "m", "outer circle radius");
  v("inner_radius_m", p.inner_radius_m, range::positive, "m", "inner circle radius");
  v("colour_rgb", p.colour_rgb, range::any, "", "annulus colour, 0..1");
}

struct CodePatternParams {
  int cells{16};          ///< cells per side of the square code map
  double cell_m{0.025};   ///< cell side (m)
  int window{5};          ///< b: every b x b window is unique (seed 001, b = 5)
  std::uint64_t seed{1};  ///< seed of the growth algorithm (deterministic map)
  bool rotation_unique{true};  ///< windows also unique under 90-degree rotations
  double side_m() const { return cells * cell_m; }
  void validate() const;
};

template <class V>
void visit_fields(V& v, CodePatternParams& p) {
  v("cells", p.cells, range::non_negative.because("0 = no code pattern"), "",
    "cells per side of the square code map");
  v("cell_m", p.cell_m, range::positive, "m", "cell side");
  v("window", p.window, range::closed(2, 6), "",
    "b: every b x b window is unique (seed 001, b = 5)");
  v("seed", p.seed, range::any, "", "seed of the growth algorithm (deterministic map)");
  v("rotation_unique", p.rotation_unique, range::any, "",
    "windows also unique under 90-degree rotations");
}

struct TargetGeometry {
  Eigen::Vector2d platform_size_m{1.8, 1.8};  ///< top surface extent along P x and y (m)
  double platform_thickness_m{0.04};          ///< plate thickness (m)
  int texture_px{4096};                       ///< texture side (px), square texture
  Eigen::Vector3d background_rgb{1.0, 1.0, 1.0};
  std::vector<RingSet> rings;                 ///< the seven ring sets
  CodePatternParams code;

  double px_per_m() const { return texture_px / platform_size_m.x(); }
  const RingSet& ring(int id) const;
  void validate() const;

  // Loads and validates a target YAML (e.g. models/target.yaml).
  static TargetGeometry load(const std::string& path);
};

template <class V>
void visit_fields(V& v, TargetGeometry& p) {
  v("platform_size_m", p.platform_size_m, range::any, "m", "top surface extent along P x and y");
  v("platform_thickness_m", p.platform_thickness_m, range::positive, "m", "plate thickness");
  v("texture_px", p.texture_px, range::closed(256, 8192), "px", "texture side");
  v("background_rgb", p.background_rgb, range::any, "", "");
  v.list("ring_sets", p.rings);
  v.nested("code_pattern", p.code);
}

// The code map, row-major, cells x cells, 1 = dark. Row 0 is the +y edge of the code square,
// column 0 its -x edge (same orientation as the texture). Deterministic for a given seed.
// Implements the random growth of seed 001 section 2 in raster order with backtracking:
// each new cell that completes a b x b window takes a value whose window code B (eq. 2) is
// unused; with rotation_unique, the window's four rotations must be unused too.
std::vector<std::uint8_t> generate_code_map(const CodePatternParams& p);

// The b x b window code (seed 001 eq. 2: the window read row-major as a base-2 number).
std::uint32_t code_window_value(const std::vector<std::uint8_t>& map, int cells, int row,
                                int col, int window);

// Draws the target texture (BGR 8-bit, texture_px square) with area-coverage antialiasing,
// in the texture convention above. Platform points outside the rings and code are background.
cv::Mat render_target_texture(const TargetGeometry& g);

// P-frame coordinates of texture pixel (u, v) and back (the texture convention above).
Eigen::Vector2d texture_to_platform(const TargetGeometry& g, double u, double v);
Eigen::Vector2d platform_to_texture(const TargetGeometry& g, const Eigen::Vector2d& p_P_m);

}  // namespace lander
