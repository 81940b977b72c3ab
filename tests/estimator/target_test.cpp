// Target geometry (models/target.yaml), code map and texture.
#include "lander/estimator/target.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <set>

namespace lander {
namespace {

const std::string kTargetYaml = std::string(LANDER_MODELS_DIR) + "/target.yaml";

TEST(TargetGeometry, ProjectTargetLoadsAndHasSevenRingSets) {
  const TargetGeometry g = TargetGeometry::load(kTargetYaml);
  ASSERT_EQ(g.rings.size(), 7u);
  EXPECT_NEAR(g.ring(0).centre_P_m.norm(), 0.0, 1e-12);
  // The six outer sets lie on a regular hexagon around the centre set.
  const double r_hex = g.ring(1).centre_P_m.norm();
  for (int id = 1; id <= 6; ++id) {
    EXPECT_NEAR(g.ring(id).centre_P_m.norm(), r_hex, 1e-9) << "ring " << id;
  }
}

TEST(TargetGeometry, DefaultIsInvalidWithoutRingsAndSaysWhy) {
  TargetGeometry g;
  try {
    g.validate();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("ring_sets"), std::string::npos) << e.what();
  }
}

TEST(TargetGeometry, SaveLoadRoundTrip) {
  const TargetGeometry g = TargetGeometry::load(kTargetYaml);
  const YAML::Node saved = params_to_yaml(g);
  TargetGeometry g2;
  read_params(saved, "<saved>", g2);
  EXPECT_EQ(yaml_to_string(params_to_yaml(g2)), yaml_to_string(saved));
  ASSERT_EQ(g2.rings.size(), g.rings.size());
  for (std::size_t i = 0; i < g.rings.size(); ++i) {
    EXPECT_EQ(g2.rings[i].centre_P_m, g.rings[i].centre_P_m);
    EXPECT_EQ(g2.rings[i].inner_radius_m, g.rings[i].inner_radius_m);
  }
}

TEST(TargetGeometry, UnknownKeyIsRejectedWithFileLineAndKey) {
  const YAML::Node n = YAML::Load("platform_size_m: [1.8, 1.8]\nring_sets:\n  - {id: 0, bogus: 1}\n");
  TargetGeometry g;
  try {
    read_params(n, "t.yaml", g);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("t.yaml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("ring_sets[0].bogus"), std::string::npos) << msg;
  }
}

TEST(TargetGeometry, BadValueNamesTheField) {
  TargetGeometry g = TargetGeometry::load(kTargetYaml);
  g.rings[2].inner_radius_m = g.rings[2].outer_radius_m * 1.1;
  try {
    g.validate();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("inner_radius_m"), std::string::npos) << e.what();
  }
}

TEST(TargetGeometry, CrossRatioMatchesFourPointDefinition) {
  // Cr{a,b;c,d} = ((c-a)(d-b)) / ((c-b)(d-a)) for a=-R, b=-r, c=r, d=R.
  RingSet r;
  r.outer_radius_m = 0.2;
  r.inner_radius_m = 0.08;
  const double a = -0.2, b = -0.08, c = 0.08, d = 0.2;
  EXPECT_NEAR(r.cross_ratio(), ((c - a) * (d - b)) / ((c - b) * (d - a)), 1e-12);
}

TEST(CodeMap, EveryWindowIsUniqueIncludingRotations) {
  CodePatternParams p;
  p.cells = 16;
  p.window = 5;
  p.seed = 7;
  const auto map = generate_code_map(p);
  ASSERT_EQ(map.size(), 256u);
  std::set<std::uint32_t> seen;
  const int n = p.cells, b = p.window;
  for (int r = 0; r + b <= n; ++r) {
    for (int c = 0; c + b <= n; ++c) {
      // Read the window and its three rotations directly from the map.
      for (int rot = 0; rot < 4; ++rot) {
        std::uint32_t v = 0;
        for (int i = 0; i < b; ++i) {
          for (int j = 0; j < b; ++j) {
            int ii = i, jj = j;
            for (int t = 0; t < rot; ++t) {  // rotate index by 90 degrees
              const int tmp = ii;
              ii = b - 1 - jj;
              jj = tmp;
            }
            v = (v << 1) | map[(r + ii) * n + (c + jj)];
          }
        }
        EXPECT_TRUE(seen.insert(v).second) << "window (" << r << "," << c << ") rot " << rot;
      }
    }
  }
}

TEST(CodeMap, SameSeedSameMapAndDifferentSeedDifferentMap) {
  CodePatternParams p;
  const auto a = generate_code_map(p);
  const auto b = generate_code_map(p);
  EXPECT_EQ(a, b);
  p.seed += 1;
  EXPECT_NE(generate_code_map(p), a);
}

TEST(TargetTexture, EachRingHasItsAreaAndCentre) {
  TargetGeometry g = TargetGeometry::load(kTargetYaml);
  g.texture_px = 1024;  // small texture: the test needs areas and centroids, not detail
  const cv::Mat tex = render_target_texture(g);
  ASSERT_EQ(tex.rows, 1024);
  cv::Mat grey;
  cv::cvtColor(tex, grey, cv::COLOR_BGR2GRAY);
  const double s = g.px_per_m();
  for (int id = 1; id <= 6; ++id) {  // outer sets: nothing else within their bounding box
    const RingSet& ring = g.ring(id);
    const Eigen::Vector2d c = platform_to_texture(g, ring.centre_P_m);
    const int R = static_cast<int>(std::ceil(ring.outer_radius_m * s)) + 2;
    double mass = 0, mu = 0, mv = 0;
    for (int v = static_cast<int>(c.y()) - R; v <= static_cast<int>(c.y()) + R; ++v) {
      for (int u = static_cast<int>(c.x()) - R; u <= static_cast<int>(c.x()) + R; ++u) {
        const double dark = 1.0 - grey.at<std::uint8_t>(v, u) / 255.0;
        mass += dark;
        mu += dark * u;
        mv += dark * v;
      }
    }
    const double area_px = M_PI * (std::pow(ring.outer_radius_m, 2) - std::pow(ring.inner_radius_m, 2)) * s * s;
    // 0.2 %: area-coverage antialiasing leaves only the 8-bit rounding of edge pixels.
    EXPECT_NEAR(mass / area_px, 1.0, 2e-3) << "ring " << id;
    // 0.01 px: the dark mass is symmetric about the true centre up to that rounding.
    EXPECT_NEAR(mu / mass, c.x(), 0.01) << "ring " << id;
    EXPECT_NEAR(mv / mass, c.y(), 0.01) << "ring " << id;
  }
}

}  // namespace
}  // namespace lander
