// Code-map localisation (seed 001; vision_code.h): placement of read cells in the map at
// every rotation, rejection of inconsistent reads, and poses on rendered close-range views.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include <opencv2/imgproc.hpp>

#include "estimator/support/vision_synth.h"
#include "lander/estimator/vision_code.h"
#include "lander/estimator/vision_detector.h"

namespace lander {
namespace {

const CameraModel kCam{};

// Observed cells of the map window with top-left cell (col0, row0), size w x w, seen rotated
// by q quarter turns: observed (a, b) maps to map cell rot_q(a, b) + offset (vision_code.h).
std::vector<ObservedCell> observe_window(const std::vector<std::uint8_t>& map, int n, int col0,
                                         int row0, int w, int q) {
  std::vector<ObservedCell> out;
  const int qi = (4 - q) % 4;
  for (int row = row0; row < row0 + w; ++row) {
    for (int col = col0; col < col0 + w; ++col) {
      // Inverse rotation of the cell centre (2 col + 1, 2 row + 1) / 2.
      const Eigen::Vector2i r = rotate_lattice(2 * col + 1, 2 * row + 1, qi);
      out.push_back({(r.x() - 1) / 2, (r.y() - 1) / 2, map[row * n + col]});
    }
  }
  return out;
}

// Given every 5 x 5 window of the map seen at each of the four rotations, the placement is
// found with the right rotation and no disagreeing cell.
TEST(VisionCode, EveryWindowIsPlacedAtEveryRotation) {
  const TargetGeometry& g = test::default_target();
  const auto map = generate_code_map(g.code);
  const int n = g.code.cells, b = g.code.window;
  const VisionParams p;
  for (int q = 0; q < 4; ++q) {
    for (int row0 = 0; row0 + b <= n; row0 += 1) {
      for (int col0 = 0; col0 + b <= n; col0 += 1) {
        const auto cells = observe_window(map, n, col0, row0, b, q);
        const CodePlacement pl = place_code_cells(cells, g, map, p);
        ASSERT_TRUE(pl.found) << "window " << col0 << "," << row0 << " q " << q << ": " << pl.reason;
        EXPECT_EQ(pl.rotation, q);
        EXPECT_EQ(pl.mismatched, 0);
        // The observed cell 0 must land on its map cell.
        const Eigen::Vector2i r = rotate_lattice(2 * cells[0].a + 1, 2 * cells[0].b + 1, pl.rotation);
        EXPECT_EQ((r.x() - 1) / 2 + pl.col_offset, col0);
        EXPECT_EQ((r.y() - 1) / 2 + pl.row_offset, row0);
      }
    }
  }
}

// A read whose cells are a mirror image of the map (wrong handedness: not a rotation) or a
// map of another seed matches nowhere.
TEST(VisionCode, MirroredOrForeignCellsAreNotPlaced) {
  const TargetGeometry& g = test::default_target();
  const auto map = generate_code_map(g.code);
  const int n = g.code.cells;
  const VisionParams p;
  CodePatternParams other = g.code;
  other.seed = g.code.seed + 1;
  const auto foreign = generate_code_map(other);
  int placed_mirror = 0, placed_foreign = 0;
  for (int row0 = 0; row0 + 7 <= n; row0 += 3) {
    for (int col0 = 0; col0 + 7 <= n; col0 += 3) {
      auto cells = observe_window(map, n, col0, row0, 7, 0);
      for (auto& c : cells) c.a = -c.a;  // mirror
      placed_mirror += place_code_cells(cells, g, map, p).found;
      placed_foreign += place_code_cells(observe_window(foreign, n, col0, row0, 7, 1), g, map, p).found;
    }
  }
  EXPECT_EQ(placed_mirror, 0);
  EXPECT_EQ(placed_foreign, 0);
}

// Given a 7 x 7 read with corrupted cells: one flipped cell of 49 (2 %, under the 3 % gate)
// is still placed correctly; a corrupted 3 x 3 block is refused, never placed elsewhere.
TEST(VisionCode, CorruptedCellsGiveNoWrongPlacement) {
  const TargetGeometry& g = test::default_target();
  const auto map = generate_code_map(g.code);
  const int n = g.code.cells;
  const VisionParams p;
  for (int q = 0; q < 4; ++q) {
    for (int row0 = 0; row0 + 7 <= n; row0 += 3) {
      for (int col0 = 0; col0 + 7 <= n; col0 += 3) {
        auto cells = observe_window(map, n, col0, row0, 7, q);
        auto one = cells;
        one[24].dark ^= 1;
        const CodePlacement p1 = place_code_cells(one, g, map, p);
        ASSERT_TRUE(p1.found) << p1.reason;
        EXPECT_EQ(p1.rotation, q);
        EXPECT_EQ(p1.mismatched, 1);
        auto block = cells;
        for (int i : {0, 1, 2, 7, 8, 9, 14, 15, 16}) block[i].dark ^= 1;
        const CodePlacement p2 = place_code_cells(block, g, map, p);
        EXPECT_FALSE(p2.found) << "window " << col0 << "," << row0;
      }
    }
  }
}

// Given random reads (windows of 5-12 cells, partly off the map, every rotation, up to 10 %
// of cells flipped), the placement search by bit masks (cells read once) and the one cell by
// cell (taken when a cell repeats) rank every placement alike: with every cell read twice,
// all scores double, so the same placement wins with twice the counts.
TEST(VisionCode, BitMaskAndCellByCellSearchesAgree) {
  const TargetGeometry& g = test::default_target();
  const auto map = generate_code_map(g.code);
  const int n = g.code.cells;
  const VisionParams p;
  std::mt19937 rng(20261203);
  std::uniform_int_distribution<int> size(5, 12), start(-4, n - 2), turn(0, 3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int found = 0;
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    const int w = size(rng), col0 = start(rng), row0 = start(rng), q = turn(rng);
    const double flip = 0.1 * u(rng);
    std::vector<ObservedCell> cells;
    for (int row = row0; row < row0 + w; ++row) {
      for (int col = col0; col < col0 + w; ++col) {
        const bool on_map = row >= 0 && col >= 0 && row < n && col < n;
        std::uint8_t v = on_map ? map[row * n + col] : 0;  // off the map: light background
        if (u(rng) < flip) v ^= 1;
        const Eigen::Vector2i r = rotate_lattice(2 * col + 1, 2 * row + 1, (4 - q) % 4);
        cells.push_back({(r.x() - 1) / 2, (r.y() - 1) / 2, v});
      }
    }
    std::vector<ObservedCell> twice = cells;
    twice.insert(twice.end(), cells.begin(), cells.end());
    const CodePlacement once = place_code_cells(cells, g, map, p);
    const CodePlacement doubled = place_code_cells(twice, g, map, p);
    SCOPED_TRACE("trial " + std::to_string(t));
    EXPECT_EQ(doubled.rotation, once.rotation);
    EXPECT_EQ(doubled.col_offset, once.col_offset);
    EXPECT_EQ(doubled.row_offset, once.row_offset);
    EXPECT_EQ(doubled.compared, 2 * once.compared);
    EXPECT_EQ(doubled.mismatched, 2 * once.mismatched);
    EXPECT_EQ(doubled.runner_up_mismatched, once.runner_up_mismatched < 0 ? -1 : 2 * once.runner_up_mismatched);
    found += once.found;
  }
  // Both branches of the gates are exercised: 53 of the 300 reads are placed at this seed
  // (the rest too flipped, too far off the map or without a full window); the floor sits
  // 15 % under it.
  EXPECT_GE(found, 45);
  EXPECT_LT(found, trials);
}

// Given frames with a regular cell grid that is not the code map (a checkerboard, random
// cells, each slightly rotated), when the code is searched, then the grid may be found but
// no placement is accepted: no pose.
TEST(VisionCode, ForeignGridsGiveNoPose) {
  const TargetGeometry& g = test::default_target();
  const VisionParams p;
  cv::RNG rng(3);
  for (int kind = 0; kind < 4; ++kind) {
    const int cell = 30 + 10 * kind;
    const int big = 2000;
    cv::Mat canvas(big, big, CV_8UC1, cv::Scalar(235));
    for (int r = 0; r * cell < big; ++r) {
      for (int c = 0; c * cell < big; ++c) {
        const bool dark = kind % 2 == 0 ? (r + c) % 2 == 0 : rng.uniform(0, 2) == 1;
        if (dark) {
          cv::rectangle(canvas, cv::Rect(c * cell, r * cell, cell, cell), cv::Scalar(20),
                        cv::FILLED);
        }
      }
    }
    const cv::Mat R = cv::getRotationMatrix2D(cv::Point2f(big / 2.0f, big / 2.0f), 7.0 + 11 * kind, 1.0);
    cv::Mat rot;
    cv::warpAffine(canvas, rot, R, canvas.size(), cv::INTER_AREA);
    const cv::Mat img = rot(cv::Rect((big - kCam.width_px) / 2, (big - kCam.height_px) / 2,
                                     kCam.width_px, kCam.height_px)).clone();
    const CodeDetection c = detect_code_pattern(img, kCam, g, p);
    EXPECT_FALSE(c.detected) << "kind " << kind << ": " << c.reason;
    EXPECT_FALSE(c.reason.empty());
    std::printf("foreign grid %d: %s\n", kind, c.reason.c_str());
  }
}

}  // namespace
}  // namespace lander
