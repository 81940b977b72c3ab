// Config tests (STYLE.md 3) for the vision params and the camera calibration file.
#include <gtest/gtest.h>

#include "lander/estimator/vision_detector.h"
#include "lander/estimator/vision_params.h"

namespace lander {
namespace {

TEST(VisionParams, DefaultIsValid) { EXPECT_NO_THROW(VisionParams{}.validate()); }

TEST(VisionParams, SaveLoadRoundTrip) {
  VisionParams p;
  p.gaussian_sigma_px = 1.25;
  p.adaptive_threshold = true;
  p.adaptive_block_px = 31;
  p.ratio_tol = 0.021;
  p.rho_max = 0.05;
  p.min_rings = 5;
  p.edge_samples = 64;
  p.tracking = false;
  p.code_enabled = false;
  p.code_min_cell_px = 10.5;
  p.code_threshold_block_px = 151;
  p.code_max_mismatch_fraction = 0.05;
  p.centre_ring_pose = false;
  p.tracked_yaw_sigma_rad = 0.1;
  p.max_reproj_fraction = 0.02;
  p.max_centre_reproj_fraction = 0.03;
  const YAML::Node node = YAML::Load(yaml_to_string(params_to_yaml(p)));
  VisionParams q;
  read_params(node, "roundtrip.yaml", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_EQ(q.gaussian_sigma_px, 1.25);
  EXPECT_TRUE(q.adaptive_threshold);
  EXPECT_EQ(q.adaptive_block_px, 31);
  EXPECT_EQ(q.min_rings, 5);
  EXPECT_FALSE(q.tracking);
  EXPECT_FALSE(q.code_enabled);
  EXPECT_EQ(q.code_min_cell_px, 10.5);
  EXPECT_EQ(q.code_threshold_block_px, 151);
  EXPECT_EQ(q.code_max_mismatch_fraction, 0.05);
  EXPECT_FALSE(q.centre_ring_pose);
  EXPECT_EQ(q.tracked_yaw_sigma_rad, 0.1);
  EXPECT_EQ(q.max_reproj_fraction, 0.02);
  EXPECT_EQ(q.max_centre_reproj_fraction, 0.03);
}

TEST(VisionParams, BadValueNamesField) {
  const auto expect_names = [](const char* yaml, const char* field) {
    VisionParams p;
    try {
      read_params(YAML::Load(yaml), "bad.yaml", p);
      FAIL() << "no exception for " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  expect_names("min_rings: 3", "min_rings");
  expect_names("adaptive_block_px: 20", "adaptive_block_px");
  expect_names("rho_max: 0", "rho_max");
  expect_names("ratio_tol: -1", "ratio_tol");
  expect_names("no_such_key: 1", "no_such_key");
  expect_names("code_threshold_block_px: 100", "code_threshold_block_px");
  // The scaling gates: a negative fraction, or one that lets a misidentified ring through
  // (neighbouring sets are about one extent apart in the image), is refused by name.
  expect_names("max_reproj_fraction: -0.01", "max_reproj_fraction");
  expect_names("max_reproj_fraction: 0.2", "max_reproj_fraction");
  expect_names("max_centre_reproj_fraction: 0.5", "max_centre_reproj_fraction");
  expect_names("code_max_reproj_fraction: 0.1", "code_max_reproj_fraction");
  expect_names("code_min_cell_px: 2", "code_min_cell_px");
  expect_names("code_max_mismatch_fraction: 0.5", "code_max_mismatch_fraction");
  expect_names("code_min_corners: 3", "code_min_corners");
  expect_names("combine_max_angle_rad: 0", "combine_max_angle_rad");
}

TEST(VisionParams, DefaultCameraFileLoadsAndMatchesDefaults) {
  const CameraModel cam = load_camera_model(LANDER_MODELS_DIR "/camera_default.yaml");
  const CameraModel def;
  EXPECT_EQ(cam.width_px, def.width_px);
  EXPECT_EQ(cam.height_px, def.height_px);
  EXPECT_EQ(cam.fx_px, def.fx_px);
  EXPECT_EQ(cam.cx_px, def.cx_px);
  EXPECT_EQ(cam.cy_px, def.cy_px);
  EXPECT_FALSE(cam.has_distortion());
  EXPECT_THROW(load_camera_model("/nonexistent/camera.yaml"), ConfigError);
}

}  // namespace
}  // namespace lander
