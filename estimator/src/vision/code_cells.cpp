// The code map's stages 3-4 (code_stages.h): the lattice's cells read as dark or light, and
// the read cells placed in the globally unique code map (place_code_cells, vision_code.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>

#include "lander/estimator/vision_code.h"
#include "vision/code_stages.h"
#include "vision/internal.h"

namespace lander {

namespace vision_internal::code_map {

namespace {

// Cell reading: samples in the inner half of the cell (4 x 4) avoid the blurred edges.
constexpr int kCellSamples = 4;
// A cell whose mean lies within this fraction of the class separation from the threshold is
// unknown (straddles an edge, e.g. the ring annulus, or is blurred).
constexpr double kAmbiguousFrac = 0.2;

// Cells read against their local white (detect_code_pattern, step 4). The ink renders near
// 0 (a dark cell reads below 0.1 of its white, blurred ones too), a white cell under a
// shadow the closing followed near 1, and one under a thin shadow the closing filled in (an
// arm's, ~1 cell wide) at the shadow's light, 10-50 %: dark below 0.2 of the local white,
// white above 0.45, unknown between (on 30 frames of a shadowed landing 0.2/0.45 placed the
// code in 18, 0.3/0.7 in 12; 0.12/0.3 and 0.15/0.35 also in 18).
constexpr double kLocalDarkBelow = 0.2;
constexpr double kLocalWhiteAbove = 0.45;

// Lattice cell (a, b) read from `grey` through H, appended to `reads` with its shortest side
// to `cell_sides`: if it lies wholly in view and is at least 0.8 minc px across.
void read_cell(const cv::Mat& grey, const CameraModel& cam, const Eigen::Matrix3d& H, int a,
               int b, double minc, std::vector<CellRead>& reads, std::vector<double>& cell_sides) {
  Eigen::Vector2d corner[4];
  bool ok = true;
  const int da[4] = {0, 1, 1, 0}, db[4] = {0, 0, 1, 1};
  for (int k = 0; k < 4 && ok; ++k) {
    corner[k] = apply_h(H, Eigen::Vector2d(a + da[k], b + db[k]));
    const Eigen::Vector2d r = cam.distort_px(corner[k]);
    ok = r.x() >= 1 && r.y() >= 1 && r.x() <= grey.cols - 2 && r.y() <= grey.rows - 2;
  }
  if (!ok) return;
  double side = 1e18;
  for (int k = 0; k < 4; ++k) side = std::min(side, (corner[(k + 1) % 4] - corner[k]).norm());
  if (side < 0.8 * minc) return;
  cell_sides.push_back(side);
  double sum = 0.0;
  for (int i = 0; i < kCellSamples; ++i) {
    for (int j = 0; j < kCellSamples; ++j) {
      const double u = a + 0.25 + 0.5 * (i + 0.5) / kCellSamples;
      const double v = b + 0.25 + 0.5 * (j + 0.5) / kCellSamples;
      const Eigen::Vector2d r = cam.distort_px(apply_h(H, Eigen::Vector2d(u, v)));
      sum += bilinear(grey, r.x(), r.y());
    }
  }
  reads.push_back({a, b, sum / (kCellSamples * kCellSamples)});
}

}  // namespace

ExtendedMap extended_map(const TargetGeometry& g, const std::vector<std::uint8_t>& map) {
  ExtendedMap m;
  m.n = g.code.cells;
  const double inner_r = central_inner_radius_m(g);
  const double half = 0.5 * g.code.side_m(), cell = g.code.cell_m;
  m.E = std::max(0, static_cast<int>(std::ceil((inner_r - half) / cell)) + 1);
  m.w = m.n + 2 * m.E;
  m.v.assign(static_cast<std::size_t>(m.w) * m.w, 2);
  for (int row = -m.E; row < m.n + m.E; ++row) {
    for (int col = -m.E; col < m.n + m.E; ++col) {
      std::uint8_t val = 2;
      if (row >= 0 && col >= 0 && row < m.n && col < m.n) {
        val = map[row * m.n + col] ? 1 : 0;
      } else {
        // Background if the whole cell lies inside the inner circle (1 mm margin).
        bool inside = true;
        for (int dc = 0; dc <= 1; ++dc) {
          for (int dr = 0; dr <= 1; ++dr) {
            const double x = -half + (col + dc) * cell, y = half - (row + dr) * cell;
            if (std::hypot(x, y) > inner_r - 0.001) inside = false;
          }
        }
        if (inside) val = 0;
      }
      m.v[(row + m.E) * m.w + (col + m.E)] = val;
    }
  }
  return m;
}

double central_inner_radius_m(const TargetGeometry& g) {
  double inner_r = 0.0;
  for (const auto& r : g.rings) {
    if (r.centre_P_m.norm() < 1e-9) inner_r = r.inner_radius_m;
  }
  return inner_r;
}

std::optional<CellReads> read_lattice_cells(const cv::Mat& grey, const CameraModel& cam,
                                            const GridLattice& lattice, const TargetGeometry& g,
                                            const VisionParams& p, std::string& why) {
  CellReads out;
  out.amin = 1 << 30, out.amax = -(1 << 30), out.bmin = 1 << 30, out.bmax = -(1 << 30);
  for (const auto& l : lattice.labels) {
    out.amin = std::min(out.amin, l.x());
    out.amax = std::max(out.amax, l.x());
    out.bmin = std::min(out.bmin, l.y());
    out.bmax = std::max(out.bmax, l.y());
  }
  const int span_cap = 2 * g.code.cells + 16;
  if (out.amax - out.amin > span_cap || out.bmax - out.bmin > span_cap) {
    why = "lattice too large";
    return std::nullopt;
  }
  // Every cell of the labels' box and one more row and column before it.
  std::vector<double> cell_sides;
  for (int b = out.bmin - 1; b <= out.bmax; ++b) {
    for (int a = out.amin - 1; a <= out.amax; ++a) {
      read_cell(grey, cam, lattice.H, a, b, p.code_min_cell_px, out.reads, cell_sides);
    }
  }
  if (out.reads.size() < 4) {
    why = "no cells in view";
    return std::nullopt;
  }
  std::nth_element(cell_sides.begin(), cell_sides.begin() + cell_sides.size() / 2, cell_sides.end());
  out.cell_px = cell_sides[cell_sides.size() / 2];
  return out;
}

std::optional<std::vector<ObservedCell>> classify_cells(const std::vector<CellRead>& reads,
                                                        const VisionParams& p, std::string& why) {
  // Two-class (Otsu) threshold on the cell means.
  std::vector<double> vals;
  for (const auto& r : reads) vals.push_back(r.mean);
  std::sort(vals.begin(), vals.end());
  const vision_internal::OtsuSplit split = vision_internal::otsu_split_sorted(vals);
  const double lo = split.mean_lo, hi = split.mean_hi;
  if (hi - lo < p.code_min_contrast) {
    why = "cell contrast " + std::to_string(hi - lo) + " below the gate";
    return std::nullopt;
  }
  const double mid = 0.5 * (lo + hi);
  std::vector<ObservedCell> cells;
  for (const auto& r : reads) {
    if (std::abs(r.mean - mid) < kAmbiguousFrac * (hi - lo)) continue;
    cells.push_back({r.a, r.b, static_cast<std::uint8_t>(r.mean < mid ? 1 : 0)});
  }
  return cells;
}

std::vector<ObservedCell> read_cells_local_white(const std::vector<CellRead>& reads, int amin,
                                                 int amax, int bmin, int bmax) {
  const int w = amax - amin + 3, h = bmax - bmin + 3;
  auto at = [&](int a, int b) { return (b - bmin + 1) * w + (a - amin + 1); };
  const double kNone = -1.0;
  std::vector<double> mean(static_cast<std::size_t>(w) * h, kNone);
  for (const auto& r : reads) mean[at(r.a, r.b)] = r.mean;
  auto filter = [&](const std::vector<double>& in, bool take_max) {
    std::vector<double> out(in.size(), kNone);
    for (int b = bmin - 1; b <= bmax + 1; ++b) {
      for (int a = amin - 1; a <= amax + 1; ++a) {
        if (in[at(a, b)] == kNone) continue;
        double v = in[at(a, b)];
        for (int db = -1; db <= 1; ++db) {
          for (int da = -1; da <= 1; ++da) {
            const int aa = a + da, bb = b + db;
            if (aa < amin - 1 || aa > amax + 1 || bb < bmin - 1 || bb > bmax + 1) continue;
            const double q = in[at(aa, bb)];
            if (q == kNone) continue;
            v = take_max ? std::max(v, q) : std::min(v, q);
          }
        }
        out[at(a, b)] = v;
      }
    }
    return out;
  };
  const std::vector<double> white = filter(filter(mean, true), false);
  std::vector<ObservedCell> cells;
  for (const auto& r : reads) {
    const double wl = white[at(r.a, r.b)];
    if (!(wl > 0)) continue;
    const double v = r.mean / wl;
    if (v >= kLocalDarkBelow && v <= kLocalWhiteAbove) continue;
    cells.push_back({r.a, r.b, static_cast<std::uint8_t>(v < kLocalDarkBelow ? 1 : 0)});
  }
  return cells;
}

CellPlacement place_read_cells(const std::vector<ObservedCell>& cells, const CellReads& reads,
                               const TargetGeometry& g, const std::vector<std::uint8_t>& map,
                               const VisionParams& p) {
  CellPlacement out;
  out.cells_read = static_cast<int>(cells.size());
  out.placement = place_code_cells(cells, g, map, p);
  if (!out.placement.found && p.code_local_white) {
    // Under a shadow (the vehicle's own, in the last metre) one level for every cell reads
    // the shadowed white cells as dark. Read again, each cell against its local white: the
    // closing of the cell means over the lattice (the largest of each 3 x 3 neighbourhood,
    // then the smallest of those over 3 x 3) follows a shadow's edge wherever each 3 x 3
    // block holds a white cell, and fills the dark cells in. Clean frames never get here
    // unless the one level failed anyway.
    std::vector<ObservedCell> local =
        read_cells_local_white(reads.reads, reads.amin, reads.amax, reads.bmin, reads.bmax);
    CodePlacement again = place_code_cells(local, g, map, p);
    if (again.found) {
      again.reason += " (cells read against their local white: " +
                      std::to_string(local.size()) + " read; one level: " +
                      out.placement.reason + ")";
      out.placement = again;
      out.cells_read = static_cast<int>(local.size());
      out.local_white = true;
    } else {
      out.placement.reason += "; against their local white: " + again.reason;
    }
  }
  return out;
}

}  // namespace vision_internal::code_map

namespace {

using vision_internal::code_map::ExtendedMap;

// Rotated cell index of (a, b): the cell centre rotated, minus one half (an integer).
Eigen::Vector2i rotated_cell(int a, int bb, int q) {
  const Eigen::Vector2i r2 = rotate_lattice(2 * a + 1, 2 * bb + 1, q);
  return Eigen::Vector2i((r2.x() - 1) / 2, (r2.y() - 1) / 2);
}

// The best placement of `cells` in the n x n map `em` over all rotations and offsets
// (rotation, offsets, compared, mismatched set), with its score and the runner-up's.
struct PlacementSearch {
  CodePlacement best;
  int best_score, second_score, second_mis;
};

// The running best and runner-up over the placements scored so far, updated in the
// search's order (rotation, then column and row offset): a placement replaces the best only
// with a higher score, and the old best becomes the runner-up.
struct PlacementRanking {
  PlacementSearch s{};
  PlacementRanking() {
    s.best_score = std::numeric_limits<int>::min() / 2;
    s.second_score = s.best_score;
    s.second_mis = -1;
  }
  // A placement scoring at most this changes nothing (the search may skip it).
  int floor() const { return s.second_score; }
  void add(int q, int oc, int orow, int compared, int mis) {
    const int score = compared - 4 * mis;
    CodePlacement& best = s.best;
    if (score > s.best_score) {
      if (best.compared > 0) {
        s.second_score = s.best_score;
        s.second_mis = best.mismatched;
      }
      s.best_score = score;
      best.rotation = q;
      best.col_offset = oc;
      best.row_offset = orow;
      best.compared = compared;
      best.mismatched = mis;
    } else if (score > s.second_score) {
      s.second_score = score;
      s.second_mis = mis;
    }
  }
};

// The read cells turned by q quarter turns and their bounds.
struct TurnedCells {
  std::vector<Eigen::Vector2i> rc;
  int amin{1 << 30}, amax{-(1 << 30)}, bmin{1 << 30}, bmax{-(1 << 30)};
  TurnedCells(const std::vector<ObservedCell>& cells, int q) : rc(cells.size()) {
    for (std::size_t i = 0; i < cells.size(); ++i) {
      rc[i] = rotated_cell(cells[i].a, cells[i].b, q);
      amin = std::min(amin, rc[i].x());
      amax = std::max(amax, rc[i].x());
      bmin = std::min(bmin, rc[i].y());
      bmax = std::max(bmax, rc[i].y());
    }
  }
};

// The map's rows as bit masks (bit col + E of row row + E): its dark cells and its light
// ones, and both (unknown cells in neither). Usable when the extended map is at most 64
// cells wide (empty otherwise).
struct MapRowMasks {
  std::vector<std::uint64_t> dark, light, known;
  explicit MapRowMasks(const ExtendedMap& em) {
    if (em.w > 64) return;
    dark.assign(em.w, 0);
    light.assign(em.w, 0);
    known.assign(em.w, 0);
    for (int r = 0; r < em.w; ++r) {
      for (int c = 0; c < em.w; ++c) {
        const std::uint8_t v = em.v[static_cast<std::size_t>(r) * em.w + c];
        if (v == 1) dark[r] |= std::uint64_t{1} << c;
        if (v == 0) light[r] |= std::uint64_t{1} << c;
      }
      known[r] = dark[r] | light[r];
    }
  }
};

// x shifted left by s bits (right for s < 0); bits shifted past either end are lost (they are
// columns off the extended map).
std::uint64_t shifted(std::uint64_t x, int s) {
  if (s >= 64 || s <= -64) return 0;
  return s >= 0 ? x << s : x >> -s;
}

// Every offset of one turn of the cells, by bit masks: the cells of each lattice row as dark
// and light masks, compared with the map's rows as popcounts (compared: cells on known map
// cells; disagreeing: dark on light or light on dark). The same scores as the cell-by-cell
// count, in the same order. Built twice, the second for CPUs with a popcount instruction
// (chosen when the program loads).
__attribute__((target_clones("popcnt", "default"))) void rank_turn_by_masks(
    const std::vector<ObservedCell>& cells, const TurnedCells& t, int q, const ExtendedMap& em,
    const MapRowMasks& m, PlacementRanking& rank) {
  const int rows = t.bmax - t.bmin + 1, n = em.n, E = em.E;
  std::vector<std::uint64_t> dark(rows, 0), light(rows, 0);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const std::uint64_t bit = std::uint64_t{1} << (t.rc[i].x() - t.amin);
    (cells[i].dark ? dark : light)[t.rc[i].y() - t.bmin] |= bit;
  }
  for (int oc = -t.amax; oc <= n - 1 - t.amin; ++oc) {
    const int shift = t.amin + oc + E;  // bit of the lattice's first column in the map's rows
    for (int orow = -t.bmax; orow <= n - 1 - t.bmin; ++orow) {
      // Lattice rows r0..r1 lie on the map's rows.
      const int r0 = std::max(0, -(t.bmin + orow + E)), r1 = std::min(rows, em.w - (t.bmin + orow + E));
      int compared = 0, mis = 0;
      for (int r = r0; r < r1; ++r) {
        const int mr = r + t.bmin + orow + E;  // the map row under lattice row r
        const std::uint64_t d = shifted(dark[r], shift), l = shifted(light[r], shift);
        compared += __builtin_popcountll((d | l) & m.known[mr]);
        mis += __builtin_popcountll((d & m.light[mr]) | (l & m.dark[mr]));
      }
      rank.add(q, oc, orow, compared, mis);
    }
  }
}

// The same, cell by cell (any map width, repeated cells counted each time): a count stops as
// soon as the placement cannot score above the runner-up (each cell left adds at most one).
void rank_turn_by_cells(const std::vector<ObservedCell>& cells, const TurnedCells& t, int q,
                        const ExtendedMap& em, PlacementRanking& rank) {
  const int n_cells = static_cast<int>(cells.size()), n = em.n;
  for (int oc = -t.amax; oc <= n - 1 - t.amin; ++oc) {
    for (int orow = -t.bmax; orow <= n - 1 - t.bmin; ++orow) {
      int compared = 0, mis = 0;
      bool reachable = true;
      for (int i = 0; i < n_cells && reachable; ++i) {
        const int v = em.at(t.rc[i].x() + oc, t.rc[i].y() + orow);
        if (v != 2) {
          ++compared;
          mis += v != cells[i].dark;
        }
        reachable = compared - 4 * mis + (n_cells - 1 - i) > rank.floor();
      }
      if (reachable) rank.add(q, oc, orow, compared, mis);
    }
  }
}

// Whether the bit-mask count applies: the map at most 64 cells wide, each lattice cell read
// once with a value of 0 or 1, and the cells' lattice at most 64 cells both ways (a turn
// makes its rows columns).
bool masks_apply(const std::vector<ObservedCell>& cells, const ExtendedMap& em) {
  if (em.w > 64 || cells.empty()) return false;
  const TurnedCells t(cells, 0);
  const int cols = t.amax - t.amin + 1, rows = t.bmax - t.bmin + 1;
  if (cols > 64 || rows > 64) return false;
  std::vector<char> seen(static_cast<std::size_t>(cols) * rows, 0);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (cells[i].dark > 1) return false;
    char& s = seen[static_cast<std::size_t>(t.rc[i].y() - t.bmin) * cols + t.rc[i].x() - t.amin];
    if (s) return false;
    s = 1;
  }
  return true;
}

// Scores every rotation and offset that puts at least one read cell on the map: compared
// cells minus 4 x the disagreeing ones; the best and the runner-up.
PlacementSearch search_placements(const std::vector<ObservedCell>& cells, const ExtendedMap& em) {
  PlacementRanking rank;
  const bool by_masks = masks_apply(cells, em);
  const MapRowMasks masks(by_masks ? em : ExtendedMap{});
  for (int q = 0; q < 4; ++q) {
    const TurnedCells t(cells, q);
    if (by_masks) {
      rank_turn_by_masks(cells, t, q, em, masks, rank);
    } else {
      rank_turn_by_cells(cells, t, q, em, rank);
    }
  }
  return rank.s;
}

// Whether the cells placed by `best` in the n x n map contain a full b x b window; `in_map`
// receives how many map cells they cover.
bool has_full_window(const std::vector<ObservedCell>& cells, const CodePlacement& best, int n,
                     int b, int* in_map) {
  std::vector<char> seen(static_cast<std::size_t>(n) * n, 0);
  for (const auto& c : cells) {
    const Eigen::Vector2i r = rotated_cell(c.a, c.b, best.rotation);
    const int col = r.x() + best.col_offset, row = r.y() + best.row_offset;
    if (col >= 0 && row >= 0 && col < n && row < n) seen[row * n + col] = 1;
  }
  bool full = false;
  for (int r0 = 0; r0 + b <= n && !full; ++r0) {
    for (int c0 = 0; c0 + b <= n && !full; ++c0) {
      bool all = true;
      for (int r = 0; r < b && all; ++r) {
        for (int c = 0; c < b && all; ++c) all = seen[(r0 + r) * n + c0 + c];
      }
      full = all;
    }
  }
  *in_map = 0;
  for (char c : seen) *in_map += c;
  return full;
}

}  // namespace

Eigen::Vector2i rotate_lattice(int a, int b, int q) {
  switch (((q % 4) + 4) % 4) {
    case 0: return {a, b};
    case 1: return {-b, a};
    case 2: return {-a, -b};
    default: return {b, -a};
  }
}

CodePlacement place_code_cells(const std::vector<ObservedCell>& cells, const TargetGeometry& g,
                               const std::vector<std::uint8_t>& map, const VisionParams& p) {
  CodePlacement best;
  best.runner_up_mismatched = -1;
  const int n = g.code.cells, b = g.code.window;
  if (n == 0) {
    best.reason = "target has no code map";
    return best;
  }
  if (static_cast<int>(cells.size()) < b * b) {
    best.reason = std::to_string(cells.size()) + " cells read, a window needs " +
                  std::to_string(b * b);
    return best;
  }
  // The best placement over every rotation and offset, and the runner-up.
  const PlacementSearch s =
      search_placements(cells, vision_internal::code_map::extended_map(g, map));
  best = s.best;
  best.runner_up_mismatched = s.second_mis;
  // Full b x b window among the compared in-map cells.
  int in_map = 0;
  best.full_window = has_full_window(cells, best, n, b, &in_map);
  std::ostringstream os;
  // Uniqueness: a full b x b window is unique by construction of the map. Below ~0.2 m a
  // 45-deg yawed view holds no full window, so a read of at least 2 b^2 map cells is also
  // accepted: its uniqueness is then checked directly, every other placement of these cells
  // (all rotations and offsets) must score code_min_score_margin lower (disagree on at
  // least two more cells).
  if (!best.full_window && in_map < 2 * b * b) {
    os << "no full " << b << "x" << b << " window among the read cells and only " << in_map
       << " map cells (need " << 2 * b * b << ")";
  } else if (best.mismatched > p.code_max_mismatch_fraction * best.compared) {
    os << best.mismatched << " of " << best.compared << " read cells disagree with the map";
  } else if (s.best_score - s.second_score < p.code_min_score_margin) {
    os << "ambiguous placement (runner-up score " << s.second_score << " vs " << s.best_score
       << ")";
  } else {
    best.found = true;
  }
  best.reason = os.str();
  return best;
}

}  // namespace lander
