#include "lander/estimator/target.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include <opencv2/core/utility.hpp>

namespace lander {

// Cr{a, b; c, d} = ((c - a)(d - b)) / ((c - b)(d - a)) on a line, with a = o1 = -R,
// b = i1 = -r, c = i2 = r, d = o2 = R (seed 000 eq. 9). It reduces to (R + r)^2 / (4 R r),
// which depends only on the ratio r/R and decreases strictly with it on (0, 1).
double RingSet::cross_ratio() const {
  const double R = outer_radius_m, r = inner_radius_m;
  return ((r + R) * (R + r)) / ((r + r) * (R + R));
}

void RingSet::validate() const {
  check_fields(*this);
  require(inner_radius_m < outer_radius_m, "inner_radius_m", "must be < outer_radius_m");
  for (int i = 0; i < 3; ++i) {
    require(colour_rgb[i] >= 0 && colour_rgb[i] <= 1, "colour_rgb", "components in [0, 1]");
  }
}

void CodePatternParams::validate() const {
  check_fields(*this);
  require(cells == 0 || cells >= window, "cells", "must be >= window");
}

const RingSet& TargetGeometry::ring(int id) const {
  for (const auto& r : rings) {
    if (r.id == id) return r;
  }
  throw ConfigError("target has no ring set with id " + std::to_string(id));
}

void TargetGeometry::validate() const {
  check_fields(*this);
  require(platform_size_m.x() > 0 && platform_size_m.y() > 0, "platform_size_m", "must be > 0");
  require(std::abs(platform_size_m.x() - platform_size_m.y()) < 1e-9, "platform_size_m",
          "the texture is square: x and y sizes must be equal");
  require(rings.size() >= 4, "ring_sets", "need at least 4 ring sets for a pose");
  validate_nested("code_pattern", code);
  std::unordered_set<int> ids;
  for (std::size_t i = 0; i < rings.size(); ++i) {
    const RingSet& r = rings[i];
    validate_item("ring_sets", i, r);
    const std::string item = "ring_sets[" + std::to_string(i) + "]";
    require(ids.insert(r.id).second, item + ".id", "duplicate id " + std::to_string(r.id));
    const Eigen::Vector2d half = 0.5 * platform_size_m;
    require(std::abs(r.centre_P_m.x()) + r.outer_radius_m <= half.x() &&
                std::abs(r.centre_P_m.y()) + r.outer_radius_m <= half.y(),
            item + ".centre_m", "ring set " + std::to_string(r.id) + " leaves the platform");
  }
  // Cross-ratios must be distinct for the identity test (seed 000 eq. 9): 2% apart.
  for (std::size_t i = 0; i < rings.size(); ++i) {
    for (std::size_t j = i + 1; j < rings.size(); ++j) {
      const double a = rings[i].cross_ratio(), b = rings[j].cross_ratio();
      require(std::abs(a - b) > 0.02 * std::min(a, b), "ring_sets",
              "ring sets " + std::to_string(rings[i].id) + " and " + std::to_string(rings[j].id) +
                  " have nearly equal radius ratios; identity by cross-ratio needs them distinct");
    }
    for (std::size_t j = i + 1; j < rings.size(); ++j) {
      const double d = (rings[i].centre_P_m - rings[j].centre_P_m).norm();
      require(d > rings[i].outer_radius_m + rings[j].outer_radius_m, "ring_sets",
              "ring sets " + std::to_string(rings[i].id) + " and " + std::to_string(rings[j].id) +
                  " overlap");
    }
  }
  if (code.cells > 0) {
    const double half_diag = 0.5 * code.side_m() * std::sqrt(2.0);
    for (const auto& r : rings) {
      if (r.centre_P_m.norm() < 1e-12) {
        require(half_diag < r.inner_radius_m, "code_pattern",
                "code square must fit inside the central ring's inner circle");
      } else {
        require(r.centre_P_m.norm() - r.outer_radius_m > half_diag, "code_pattern",
                "code square overlaps ring set " + std::to_string(r.id));
      }
    }
  }
}

TargetGeometry TargetGeometry::load(const std::string& path) {
  TargetGeometry g;
  read_params(load_yaml_file(path), path, g);
  return g;
}

// ---------------------------------------------------------------------------------------
// Code map (seed 001 section 2).

namespace {

// SplitMix64: a tiny PRNG with the same output on every platform and standard library.
struct SplitMix64 {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
};

// Window value after rotating a b x b window by 90 degrees k times.
std::uint32_t rotate_window(std::uint32_t v, int b, int k) {
  for (int t = 0; t < k; ++t) {
    std::uint32_t out = 0;
    for (int r = 0; r < b; ++r) {
      for (int c = 0; c < b; ++c) {
        // (r, c) of the rotated window comes from (b - 1 - c, r) of the original.
        const int src = (b - 1 - c) * b + r;
        const std::uint32_t bit = (v >> (b * b - 1 - src)) & 1u;
        out |= bit << (b * b - 1 - (r * b + c));
      }
    }
    v = out;
  }
  return v;
}

}  // namespace

std::uint32_t code_window_value(const std::vector<std::uint8_t>& map, int cells, int row, int col,
                                int window) {
  std::uint32_t v = 0;
  for (int r = 0; r < window; ++r) {
    for (int c = 0; c < window; ++c) {
      v = (v << 1) | (map[(row + r) * cells + (col + c)] & 1u);
    }
  }
  return v;
}

std::vector<std::uint8_t> generate_code_map(const CodePatternParams& p) {
  const int n = p.cells, b = p.window;
  std::vector<std::uint8_t> map(static_cast<std::size_t>(n) * n, 0);
  if (n == 0) return map;
  SplitMix64 rng{p.seed};
  std::unordered_set<std::uint32_t> used;
  // Random growth in raster order: cell k gets a value; when it completes the window whose
  // bottom-right corner it is, that window's code (and its rotations) must be new. On a dead
  // end, back-track. `tried[k]` counts the values tried at cell k (0, 1 or 2).
  std::vector<int> tried(map.size(), 0), first(map.size(), 0);
  std::vector<std::vector<std::uint32_t>> added(map.size());
  long steps = 0;
  int k = 0;
  while (k < n * n) {
    if (++steps > 50'000'000) throw ConfigError("code_pattern: growth did not converge");
    if (tried[k] == 0) first[k] = static_cast<int>(rng.next() & 1u);
    if (tried[k] == 2) {  // dead end: undo and back-track
      tried[k] = 0;
      --k;
      if (k < 0) throw ConfigError("code_pattern: no unique code map exists for these params");
      for (auto v : added[k]) used.erase(v);
      added[k].clear();
      continue;
    }
    map[k] = static_cast<std::uint8_t>(first[k] ^ tried[k]);
    ++tried[k];
    const int r = k / n, c = k % n;
    if (r >= b - 1 && c >= b - 1) {
      const std::uint32_t v = code_window_value(map, n, r - b + 1, c - b + 1, b);
      std::vector<std::uint32_t> keys{v};
      if (p.rotation_unique) {
        for (int t = 1; t < 4; ++t) keys.push_back(rotate_window(v, b, t));
      }
      bool ok = true;
      for (std::size_t i = 0; i < keys.size() && ok; ++i) {
        if (used.count(keys[i])) ok = false;
        for (std::size_t j = 0; j < i && ok; ++j) ok = keys[i] != keys[j];  // no symmetric window
      }
      if (!ok) continue;
      for (auto key : keys) used.insert(key);
      added[k] = keys;
    }
    ++k;
  }
  return map;
}

// ---------------------------------------------------------------------------------------
// Texture.

Eigen::Vector2d texture_to_platform(const TargetGeometry& g, double u, double v) {
  const double s = g.px_per_m();
  return {(u + 0.5) / s - 0.5 * g.platform_size_m.x(), 0.5 * g.platform_size_m.y() - (v + 0.5) / s};
}

Eigen::Vector2d platform_to_texture(const TargetGeometry& g, const Eigen::Vector2d& p) {
  const double s = g.px_per_m();
  return {(p.x() + 0.5 * g.platform_size_m.x()) * s - 0.5,
          (0.5 * g.platform_size_m.y() - p.y()) * s - 0.5};
}

namespace {
// Fraction of a pixel of side h (m) centred at distance d (m) from a circle's centre that
// lies inside the circle of radius R: the signed distance to the edge over the pixel width,
// clamped. Exact for a straight edge crossing the pixel centre-line; at radii of hundreds
// of pixels the curvature error is far below one grey level.
inline double disc_coverage(double d, double R, double h) {
  return std::clamp(0.5 + (R - d) / h, 0.0, 1.0);
}
inline double overlap_1d(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

// A ring's texture columns [u0, u1] on one row.
struct Span {
  const RingSet* ring;
  int u0, u1;
};

// Texture columns of the platform's x within reach of x_m, two columns of margin, clipped.
void texture_columns(const TargetGeometry& g, double x_m, double reach, int* u0, int* u1) {
  const int N = g.texture_px;
  const double ua = platform_to_texture(g, {x_m - reach, 0.0}).x();
  const double ub = platform_to_texture(g, {x_m + reach, 0.0}).x();
  *u0 = std::max(0, static_cast<int>(std::floor(ua)) - 2);
  *u1 = std::min(N - 1, static_cast<int>(std::ceil(ub)) + 2);
}

// The rings whose bounding square the row at p_y (m) crosses, with their columns, in the
// rings' order (pixel side h, m).
void row_spans(const TargetGeometry& g, double p_y, double h, std::vector<Span>& spans) {
  spans.clear();
  for (const auto& ring : g.rings) {
    const double reach = ring.outer_radius_m + h;
    if (std::abs(p_y - ring.centre_P_m.y()) > reach) continue;
    Span span{&ring, 0, 0};
    texture_columns(g, ring.centre_P_m.x(), reach, &span.u0, &span.u1);
    if (span.u0 <= span.u1) spans.push_back(span);
  }
}

// The rings of `spans` covering column u blended in order into `colour` (BGR, 0-1) at the
// pixel centre (p_x, p_y) (m).
inline void blend_rings(const std::vector<Span>& spans, int u, double p_x, double p_y, double h,
                        double colour[3]) {
  for (const auto& span : spans) {
    if (u < span.u0 || u > span.u1) continue;
    const RingSet& ring = *span.ring;
    // Outside the ring's bounding square the distance test below skips it too.
    const double dx = p_x - ring.centre_P_m.x(), dy = p_y - ring.centre_P_m.y();
    if (std::abs(dx) > ring.outer_radius_m + h || std::abs(dy) > ring.outer_radius_m + h) {
      continue;
    }
    const double d = std::sqrt(dx * dx + dy * dy);
    if (d > ring.outer_radius_m + h) continue;
    const double a =
        disc_coverage(d, ring.outer_radius_m, h) - disc_coverage(d, ring.inner_radius_m, h);
    for (int ch = 0; ch < 3; ++ch) {
      colour[ch] = colour[ch] * (1.0 - a) + ring.colour_rgb[2 - ch] * a;
    }
  }
}

// The fraction of the pixel square of side h centred at (p_x, p_y) (m) that the code's dark
// cells cover.
inline double code_dark_fraction(const TargetGeometry& g, const std::vector<std::uint8_t>& code,
                                 double p_x, double p_y, double h) {
  const double code_half = 0.5 * g.code.side_m();
  // Area of each dark cell inside this pixel's square.
  const double x0 = p_x - 0.5 * h, x1 = p_x + 0.5 * h;
  const double y0 = p_y - 0.5 * h, y1 = p_y + 0.5 * h;
  const int c0 =
      std::max(0, static_cast<int>(std::floor((x0 + code_half) / g.code.cell_m)));
  const int c1 = std::min(g.code.cells - 1,
                          static_cast<int>(std::floor((x1 + code_half) / g.code.cell_m)));
  const int r0 =
      std::max(0, static_cast<int>(std::floor((code_half - y1) / g.code.cell_m)));
  const int r1 = std::min(g.code.cells - 1,
                          static_cast<int>(std::floor((code_half - y0) / g.code.cell_m)));
  double dark = 0.0;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      if (!code[r * g.code.cells + c]) continue;
      const double cx0 = -code_half + c * g.code.cell_m,
                   cy1 = code_half - r * g.code.cell_m;
      dark += overlap_1d(x0, x1, cx0, cx0 + g.code.cell_m) *
              overlap_1d(y0, y1, cy1 - g.code.cell_m, cy1);
    }
  }
  return dark / (h * h);
}

// Texture row v into `row`: the background (BGR, 0-1: bg; 8-bit: bg_px) outside every ring's
// and the code square's columns, elsewhere the rings blended in and the code's cells.
void render_row(const TargetGeometry& g, const std::vector<std::uint8_t>& code,
                const cv::Vec3d& bg, const cv::Vec3b& bg_px, int v, std::vector<Span>& spans,
                cv::Vec3b* row) {
  const int N = g.texture_px;
  const double h = 1.0 / g.px_per_m();  // pixel side (m)
  const double s_px = g.px_per_m();
  const double code_half = 0.5 * g.code.side_m();
  const double p_y = texture_to_platform(g, 0, v).y();
  row_spans(g, p_y, h, spans);
  // The code square's columns on this row (the same margin); elsewhere, with no ring's
  // span either, a pixel is the background.
  int code_u0 = N, code_u1 = -1;
  if (g.code.cells > 0 && std::abs(p_y) < code_half + h) {
    texture_columns(g, 0.0, code_half + h, &code_u0, &code_u1);
  }
  for (int u = 0; u < N; ++u) {
    if (u < code_u0 || u > code_u1) {
      bool covered = false;
      for (const auto& span : spans) covered = covered || (u >= span.u0 && u <= span.u1);
      if (!covered) {
        row[u] = bg_px;
        continue;
      }
    }
    // Scalar arithmetic (no Eigen/cv temporaries per pixel: uninlined under the
    // sanitizers, they made this texture ~15 s there), the same operations in the same
    // order as texture_to_platform(), Vector2d::norm() and Vec3d's blend.
    const double p_x = (u + 0.5) / s_px - 0.5 * g.platform_size_m.x();
    double colour[3] = {bg[0], bg[1], bg[2]};
    blend_rings(spans, u, p_x, p_y, h, colour);
    if (g.code.cells > 0 && std::abs(p_x) < code_half + h && std::abs(p_y) < code_half + h) {
      const double a = code_dark_fraction(g, code, p_x, p_y, h);
      for (double& c : colour) c = c * (1.0 - a);
    }
    for (int ch = 0; ch < 3; ++ch) {
      row[u][ch] = cv::saturate_cast<std::uint8_t>(std::lround(colour[ch] * 255.0));
    }
  }
}

}  // namespace

cv::Mat render_target_texture(const TargetGeometry& g) {
  const int N = g.texture_px;
  cv::Mat img(N, N, CV_8UC3);
  const std::vector<std::uint8_t> code = generate_code_map(g.code);
  const cv::Vec3d bg(g.background_rgb[2], g.background_rgb[1], g.background_rgb[0]);
  cv::Vec3b bg_px;
  for (int ch = 0; ch < 3; ++ch) {
    bg_px[ch] = cv::saturate_cast<std::uint8_t>(std::lround(bg[ch] * 255.0));
  }
  // Rows are independent: drawn in parallel, the same bytes as in one thread.
  // A ring can cover a pixel only within its bounding square (half side outer radius + h):
  // each row keeps the rings whose square it crosses, each with the columns of that square
  // (two columns of margin; the exact per-pixel test below decides), so a pixel visits only
  // the rings that can reach it, in the rings' order (the same blend, the same bytes).
  cv::parallel_for_(cv::Range(0, N), [&](const cv::Range& rows) {
    std::vector<Span> spans;
    spans.reserve(g.rings.size());
    for (int v = rows.start; v < rows.end; ++v) {
      render_row(g, code, bg, bg_px, v, spans, img.ptr<cv::Vec3b>(v));
    }
  });
  return img;
}

}  // namespace lander
