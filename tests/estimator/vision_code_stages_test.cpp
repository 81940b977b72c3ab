// The code map's stages on their own (code_stages.h): the contracts between them that the
// whole-frame tests (vision_code_test.cpp) only see through a pose. Given a stage's typed
// input, drawn exactly, when the stage runs, then its output is the one the input implies.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

// The stages are internal to the estimator library (no public header): included by path.
#include "../../estimator/src/vision/code_stages.h"

namespace lander {
namespace {

namespace cm = vision_internal::code_map;

// Exactly drawn inputs: the results differ from the truth by rounding only.
constexpr double kRoundingTol = 1e-9;

// Stage 2: vertex coordinates on a lattice of 12.5 px with phase 3.2 px, and polygon sides of
// one to three cells, give that spacing and phase.
TEST(VisionCodeStages, LatticeSpacingAndPhaseOfWholeCells) {
  const double delta = 12.5, x0 = 3.2;
  std::vector<double> x;
  for (int i = 0; i < 10; ++i) x.push_back(x0 + i * delta);
  const std::vector<double> lengths{12.5, 25.0, 37.5, 12.5, 12.5};
  const auto l = cm::lattice_1d(lengths, x);
  ASSERT_TRUE(l.has_value());
  EXPECT_NEAR(l->first, delta, kRoundingTol);
  EXPECT_NEAR(l->second, x0, kRoundingTol);
}

// Stage 2, the half-period trap: sides of half a cell only (the lengths alone suggest 6.25
// px) still give the vertices' own period, 12.5 px.
TEST(VisionCodeStages, LatticeOfHalfCellSidesDoublesToTheVertexPeriod) {
  std::vector<double> x;
  for (int i = 0; i < 10; ++i) x.push_back(3.2 + i * 12.5);
  const auto l = cm::lattice_1d({6.25, 6.25, 6.25, 6.25}, x);
  ASSERT_TRUE(l.has_value());
  EXPECT_NEAR(l->first, 12.5, kRoundingTol);
  EXPECT_NEAR(l->second, 3.2, kRoundingTol);
}

// Stage 2: fewer than four vertices give no lattice.
TEST(VisionCodeStages, LatticeNeedsFourVertices) {
  EXPECT_FALSE(cm::lattice_1d({12.5}, {0.0, 12.5, 25.0}).has_value());
}

// Stage 2: long segments on six lines through one image point (a fan all around it) give
// that vanishing point (normalised coordinates), and a short side across them is dropped as
// an outlier.
TEST(VisionCodeStages, VanishingPointOfConvergingSidesDropsTheOutlier) {
  const Eigen::Vector2d c(640.0, 360.0);
  const double f = 800.0;
  const Eigen::Vector2d V(900.0, 300.0);  // px
  std::vector<cm::Segment> segs;
  for (int k = 0; k < 6; ++k) {
    const double th = k * M_PI / 3.0;
    const Eigen::Vector2d p0 = V + 300.0 * Eigen::Vector2d(std::cos(th), std::sin(th));
    const Eigen::Vector2d p1 = p0 + 100.0 * (V - p0).normalized();
    segs.push_back({p0, p1, (p1 - p0).norm(), 0.0});
  }
  // 15 px across the radial lines: its end points lie 7.5 px off the line through V.
  const Eigen::Vector2d mid = V + 250.0 * Eigen::Vector2d(std::cos(0.5), std::sin(0.5));
  const Eigen::Vector2d across(-std::sin(0.5), std::cos(0.5));
  segs.push_back({mid - 7.5 * across, mid + 7.5 * across, 15.0, 0.0});
  const auto v = cm::vanishing_point(segs, c, f);
  ASSERT_TRUE(v.has_value());
  const Eigen::Vector2d v_n = v->head<2>() / v->z();
  EXPECT_NEAR(v_n.x(), (V.x() - c.x()) / f, kRoundingTol);
  EXPECT_NEAR(v_n.y(), (V.y() - c.y()) / f, kRoundingTol);
  EXPECT_EQ(segs.size(), 6u);
}

// Stage 3: the two-class level reads dark and light cells and leaves out a read half-way
// between them (an edge straddled).
TEST(VisionCodeStages, CellsClassifiedByOneLevelLeaveTheAmbiguousOut) {
  const std::vector<cm::CellRead> reads{{0, 0, 20.0},  {1, 0, 200.0}, {2, 0, 25.0},
                                        {0, 1, 210.0}, {1, 1, 22.0},  {2, 1, 112.0}};
  std::string why;
  const auto cells = cm::classify_cells(reads, VisionParams{}, why);
  ASSERT_TRUE(cells.has_value()) << why;
  ASSERT_EQ(cells->size(), 5u);
  const int dark[5] = {1, 0, 1, 0, 1};
  for (std::size_t i = 0; i < cells->size(); ++i) {
    EXPECT_EQ((*cells)[i].a, reads[i].a);
    EXPECT_EQ((*cells)[i].b, reads[i].b);
    EXPECT_EQ((*cells)[i].dark, dark[i]) << "cell " << i;
  }
}

// Stage 3: reads without code_min_contrast between the classes are refused, saying so.
TEST(VisionCodeStages, CellsOfLowContrastAreRefused) {
  const std::vector<cm::CellRead> reads{{0, 0, 100.0}, {1, 0, 120.0}, {0, 1, 105.0}, {1, 1, 118.0}};
  std::string why;
  EXPECT_FALSE(cm::classify_cells(reads, VisionParams{}, why).has_value());
  EXPECT_NE(why.find("contrast"), std::string::npos) << why;
}

// Stage 4's second read: a checkerboard of cells with a shadow at 30 % light over the columns
// a >= 3. One level for all cells reads the shadowed white as dark; against their local
// white every cell reads as printed.
TEST(VisionCodeStages, CellsAgainstTheirLocalWhiteReadThroughAShadow) {
  std::vector<cm::CellRead> reads;
  for (int b = 0; b < 8; ++b) {
    for (int a = 0; a < 8; ++a) {
      const bool dark = (a + b) % 2 == 1;
      const double light = a >= 3 ? 0.3 : 1.0;
      reads.push_back({a, b, light * (dark ? 10.0 : 200.0)});
    }
  }
  const std::vector<ObservedCell> cells = cm::read_cells_local_white(reads, 0, 7, 0, 7);
  ASSERT_EQ(cells.size(), reads.size());
  for (const auto& c : cells) {
    EXPECT_EQ(c.dark, (c.a + c.b) % 2 == 1 ? 1 : 0) << "cell " << c.a << "," << c.b;
  }
  // The one level: some shadowed white cell reads dark.
  std::string why;
  const auto one_level = cm::classify_cells(reads, VisionParams{}, why);
  ASSERT_TRUE(one_level.has_value()) << why;
  int misread = 0;
  for (const auto& c : *one_level) misread += c.dark != ((c.a + c.b) % 2 == 1 ? 1 : 0);
  EXPECT_GT(misread, 0);
}

}  // namespace
}  // namespace lander
