#include "lander/estimator/vision_params.h"

namespace lander {

void VisionParams::validate() const {
  require(gaussian_sigma_px >= 0 && gaussian_sigma_px <= 10, "gaussian_sigma_px", "must be in [0, 10]");
  require(adaptive_block_px >= 3 && adaptive_block_px % 2 == 1, "adaptive_block_px",
          "must be odd and >= 3");
  require(close_kernel_px >= 1 && close_kernel_px <= 15, "close_kernel_px", "must be in [1, 15]");
  require(min_contour_points >= 6, "min_contour_points", "must be >= 6 (an ellipse needs 5)");
  require(min_axis_px > 0, "min_axis_px", "must be > 0");
  require(deblur_min_px >= 0 && deblur_min_px <= 200, "deblur_min_px", "must be in [0, 200]");
  require(deblur_noise_ratio > 0 && deblur_noise_ratio <= 1, "deblur_noise_ratio",
          "must be in (0, 1]");
  require(min_axis_ratio > 0 && min_axis_ratio < 1, "min_axis_ratio", "must be in (0, 1)");
  require(max_contour_fit_rms_px > 0, "max_contour_fit_rms_px", "must be > 0");
  require(edge_samples >= 12 && edge_samples <= 1024, "edge_samples", "must be in [12, 1024]");
  require(edge_search_px >= 1 && edge_search_px <= 20, "edge_search_px", "must be in [1, 20]");
  require(refine_iterations >= 1 && refine_iterations <= 10, "refine_iterations",
          "must be in [1, 10]");
  require(max_edge_fit_rms_px > 0, "max_edge_fit_rms_px", "must be > 0");
  require(edge_blur_sigma_px >= 0 && edge_blur_sigma_px <= 10, "edge_blur_sigma_px",
          "must be in [0, 10]");
  require(!shadow_pass || !shadow_levels.empty(), "shadow_levels",
          "must not be empty when shadow_pass is on");
  for (double f : shadow_levels) {
    require(f > 0 && f < 1, "shadow_levels", "each level must be in (0, 1)");
  }
  require(shadow_split_ratio > 1, "shadow_split_ratio", "must be > 1");
  require(max_centre_offset_ratio > 0, "max_centre_offset_ratio", "must be > 0");
  require(harmonic_tol_px > 0, "harmonic_tol_px", "must be > 0");
  require(harmonic_max_iter >= 2, "harmonic_max_iter", "must be >= 2");
  require(ratio_tol > 0 && ratio_tol < 0.5, "ratio_tol", "must be in (0, 0.5)");
  require(min_rings >= 4, "min_rings", "must be >= 4 (planar PnP needs four points)");
  require(max_centre_reproj_px > 0, "max_centre_reproj_px", "must be > 0");
  require(max_centre_reproj_fraction >= 0 && max_centre_reproj_fraction <= 0.1,
          "max_centre_reproj_fraction", "must be in [0, 0.1]");
  require(unfiltered_max_minor_px > 0, "unfiltered_max_minor_px", "must be > 0");
  require(unfiltered_min_ellipses >= 0, "unfiltered_min_ellipses", "must be >= 0");
  require(layout_ratio_tol > 0 && layout_ratio_tol < 0.5, "layout_ratio_tol", "must be in (0, 0.5)");
  require(layout_max_ratio_bias >= 0 && layout_max_ratio_bias < 0.5, "layout_max_ratio_bias",
          "must be in [0, 0.5)");
  require(layout_ratio_margin >= 0, "layout_ratio_margin", "must be >= 0");
  require(layout_min_ratio_sets >= 1, "layout_min_ratio_sets",
          "must be >= 1 (the ratios decide the rotation)");
  require(layout_position_tol > 0 && layout_position_tol < 0.5, "layout_position_tol",
          "must be in (0, 0.5) (neighbouring sets are one hexagon radius apart)");
  require(layout_photometric_max_minor_px >= 0 && layout_photometric_max_minor_px <= 64,
          "layout_photometric_max_minor_px", "must be in [0, 64]");
  require(layout_size_tol > 0 && layout_size_tol <= 1, "layout_size_tol", "must be in (0, 1]");
  require(zoom_max_axis_px > 0, "zoom_max_axis_px", "must be > 0");
  require(zoom_max_region_px >= 16 && zoom_max_region_px <= 2048, "zoom_max_region_px",
          "must be in [16, 2048]");
  require(zoom_max_regions >= 0 && zoom_max_regions <= 16, "zoom_max_regions", "must be in [0, 16]");
  require(platform_min_area_px >= 16, "platform_min_area_px", "must be >= 16");
  require(platform_max_quads >= 0 && platform_max_quads <= 16, "platform_max_quads",
          "must be in [0, 16]");
  require(rotation_check_margin >= 0 && rotation_check_margin < 1, "rotation_check_margin",
          "must be in [0, 1)");
  require(refine_max_iter >= 0, "refine_max_iter", "must be >= 0");
  require(refine_points_per_ellipse >= 6, "refine_points_per_ellipse", "must be >= 6");
  require(max_reproj_err_px > 0, "max_reproj_err_px", "must be > 0");
  require(max_edge_residual_px > 0, "max_edge_residual_px", "must be > 0");
  require(max_reproj_fraction >= 0 && max_reproj_fraction <= 0.05, "max_reproj_fraction",
          "must be in [0, 0.05]");
  require(rho_max > 0 && rho_max <= 1, "rho_max", "must be in (0, 1]");
  require(keyframe_reset_after >= 0, "keyframe_reset_after", "must be >= 0");
  require(roi_margin >= 0, "roi_margin", "must be >= 0");
  require(max_frames_without_detection >= 0, "max_frames_without_detection", "must be >= 0");
  require(code_min_cell_px >= 4, "code_min_cell_px", "must be >= 4");
  require(code_threshold_block_px >= 3 && code_threshold_block_px % 2 == 1,
          "code_threshold_block_px", "must be odd and >= 3");
  require(code_threshold_offset >= 0, "code_threshold_offset", "must be >= 0");
  require(code_min_contrast > 0, "code_min_contrast", "must be > 0");
  require(code_max_mismatch_fraction >= 0 && code_max_mismatch_fraction < 0.2,
          "code_max_mismatch_fraction", "must be in [0, 0.2)");
  require(code_min_score_margin >= 1, "code_min_score_margin", "must be >= 1");
  require(code_min_corners >= 4, "code_min_corners", "must be >= 4 (planar PnP)");
  require(code_max_reproj_px > 0, "code_max_reproj_px", "must be > 0");
  require(code_max_reproj_fraction >= 0 && code_max_reproj_fraction <= 0.02,
          "code_max_reproj_fraction", "must be in [0, 0.02]");
  require(tracked_yaw_sigma_rad > 0, "tracked_yaw_sigma_rad", "must be > 0");
  require(tracked_max_jump_m >= 0, "tracked_max_jump_m", "must be >= 0");
  require(tracked_max_jump_ratio >= 0, "tracked_max_jump_ratio", "must be >= 0");
  require(combine_max_angle_rad > 0, "combine_max_angle_rad", "must be > 0");
  require(combine_max_offset_ratio > 0, "combine_max_offset_ratio", "must be > 0");
}

}  // namespace lander
