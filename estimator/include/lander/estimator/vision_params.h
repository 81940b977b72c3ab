// Parameters of the ring-target pose estimator (seed 000 section 2). SI units unless the key
// says otherwise; pixels are image pixels of the full-resolution frame.
#pragma once

#include <string>
#include <vector>

#include "lander/core/params_io.h"

namespace lander {

struct VisionParams {
  // ---- pre-processing (seed 000 section 2.1) ----
  double gaussian_sigma_px{0.8};     ///< Gaussian pre-filter sigma (px), 0 = none
  bool adaptive_threshold{false};    ///< local (adaptive mean) threshold instead of global Otsu
  int adaptive_block_px{51};         ///< adaptive threshold window side (px), odd, >= 3
  double adaptive_offset{5.0};       ///< adaptive threshold offset below the local mean (grey)
  bool canny_edges{false};           ///< Canny + close on the binary image before contours
                                     ///< (the paper's chain; border following of the binary
                                     ///< image gives the same boundaries faster)
  int close_kernel_px{1};            ///< morphological close kernel side (px), 1 = none; off
                                     ///< by default: at range the 0.08 m gap between ring sets
                                     ///< is 2-3 px and a close merges neighbouring sets
  int min_contour_points{14};        ///< contours shorter than this are ignored (px)
  double min_axis_px{1.5};           ///< smallest accepted ellipse semi-axis (px)
  double min_axis_ratio{0.15};       ///< minor/major semi-axis ratio floor (about 81 deg tilt)
  double max_contour_fit_rms_px{0.6};  ///< pixel-contour ellipse fit RMS gate (px)

  // ---- sub-pixel edge refinement ----
  int edge_samples{48};              ///< edge points sampled around each ellipse
  double edge_search_px{3.0};        ///< half length of the normal profile searched (px)
  int refine_iterations{2};          ///< resample-and-refit passes
  double max_edge_fit_rms_px{0.5};   ///< sub-pixel edge fit RMS gate (px)
  double edge_blur_sigma_px{0.0};    ///< camera blur (optics, defocus) sigma beyond the pixel
                                     ///< box, for the curvature correction of edge points (px)
  bool guided_inner_search{true};    ///< look for a missing inner circle at each model ratio

  // ---- shadows (issue 12) ----
  bool shadow_pass{true};            ///< when the global threshold gives no pose, segment
                                     ///< again at the shadow_levels and fit edge points per
                                     ///< illumination: a hard shadow's edge across ring sets
                                     ///< (20-50 % light) then no longer merges them
  std::vector<double> shadow_levels{0.35, 0.25, 0.17, 0.12};  ///< threshold levels of the
                                     ///< shadow pass, fractions of the region's white
                                     ///< reference (99.5th percentile); a level between the
                                     ///< lit black and the shadowed white segments both sides
  double shadow_split_ratio{1.5};    ///< shadow pass: around one ellipse, two classes of
                                     ///< edge profiles whose median brightest values differ
                                     ///< by this factor or more are two illuminations (a
                                     ///< 50 % shadow gives 2)

  // ---- concentric pairing and identity (eq. 1-9) ----
  double max_centre_offset_ratio{0.35};  ///< |c_outer - c_inner| / inner minor axis, ceiling
  double harmonic_tol_px{1e-9};      ///< harmonic-ratio recursion stops below this step (px)
  int harmonic_max_iter{200};        ///< harmonic-ratio recursion iteration cap
  double ratio_tol{0.03};            ///< |r/R measured - r/R model| for a ring identity; the
                                     ///< closest model ratios (0.66, 0.58) are 0.08 apart

  // ---- pose (eq. 10-16) ----
  int min_rings{4};                  ///< identified centres needed for a pose (planar PnP)
  bool three_ring_pose{true};        ///< with exactly three sets identified: P3P on their
                                     ///< centres, the solution that fits the six conics (and
                                     ///< clearly better than any other P3P solution)
  double max_centre_reproj_px{3.0};  ///< centre outlier gate after the initial PnP (px)
  /// The centre gate also grows with the ring sets' extent in the image (vision internal
  /// ring_extent_px): the larger of max_centre_reproj_px and this fraction of it. See
  /// max_reproj_fraction; 0 keeps the absolute gate alone.
  double max_centre_reproj_fraction{0.05};
  // ---- unfiltered pass (issue 12: far and grazing views) ----
  bool unfiltered_pass{true};        ///< no pose from the frame, and the failed passes found
                                     ///< at least unfiltered_min_ellipses small ellipses: the
                                     ///< frame is searched again without the Gaussian pre-
                                     ///< filter (same gates). Where ring sets are 5-8 px across
                                     ///< the filter closes the small inner circles and reads
                                     ///< the ratios 0.05-0.1 low, naming sets wrongly; on larger
                                     ///< rings it is the more precise, so it stays first
  double unfiltered_max_minor_px{6.0};  ///< an ellipse counts as small below this minor
                                     ///< semi-axis (px)
  int unfiltered_min_ellipses{2};    ///< small ellipses needed to try the pass (target-free
                                     ///< frames rarely have two; the pass costs a search)
  // ---- identification by the layout (issue 12: far and grazing views; vision_layout.h) ----
  bool layout_identification{true};  ///< when the ratio-by-ratio identification gives no
                                     ///< pose, identify the sets by their places on the
                                     ///< hexagon, the ratios (photometric for small sets)
                                     ///< judged together; the pose passes the same gates
                                     ///< (README, estimator benchmark)
  double layout_ratio_tol{0.04};     ///< mean |ratio - model - common bias| of the placed
                                     ///< sets; none may exceed twice this
  double layout_max_ratio_bias{0.12};  ///< the common bias removed lies within [-this,
                                     ///< this / 2] (small rings read 0.02-0.10 low)
  double layout_ratio_margin{0.06};  ///< another identity (any) whose mean ratio error is
                                     ///< within this of the best makes the frame ambiguous
                                     ///< (synthetic: 0.03 named 0.4 % wrongly at 0.05 of
                                     ///< ratio noise, 0.06 none in 1200 views); with
                                     ///< n > 4 ratios on both sides: x sqrt(4 / n)
  int layout_min_ratio_sets{3};      ///< measured ratios (inner circles found) needed
  double layout_position_tol{0.2};   ///< a set's rectified centre within this fraction of
                                     ///< its distance from the centre (weak perspective
                                     ///< leaves 1-7 %; blur inflates the central circle)
  double layout_photometric_max_minor_px{8.0};  ///< a candidate whose minor semi-axis is at
                                     ///< most this gives the layout its photometric ratio
                                     ///< (photometric_ratio: the set's model fitted to its
                                     ///< pixels) instead of eq. (9)'s, whose inner circle is
                                     ///< then 1-3 px across the minor axis or not found at
                                     ///< all; 0 = eq. (9) only
  double layout_size_tol{0.4};       ///< rectified outer circle within a factor 1 + this of
                                     ///< the model's, and its axis ratio below 1 + this
  // ---- zoomed pass (issue 12: far and grazing views) ----
  bool zoom_pass{false};             ///< no pose from the frame: magnify the regions where the
                                     ///< failed passes found clusters of small ellipses twice
                                     ///< and search them again (same gates, in zoomed px).
                                     ///< Off until checked in the closed loop
  double zoom_max_axis_px{24.0};     ///< ellipses up to this semi-major axis seed a region
                                     ///< (larger rings are resolved at the frame's scale)
  int zoom_max_region_px{400};       ///< regions larger than this (px, either side) are skipped
  int zoom_max_regions{2};           ///< at most this many regions a frame, most ellipses first
  // ---- platform pass (issue 12: far and grazing views; vision internal platform.cpp) ----
  bool platform_pass{true};            ///< no pose from the frame: the bright quadrilaterals
                                       ///< that may be the platform's white top predict where
                                       ///< the ring sets' outer circles are (the hexagon's two
                                       ///< placements in the square); those guesses are refined
                                       ///< to sub-pixel edges and searched as contours are, under
                                       ///< the same identification and gates. For sets a few px
                                       ///< across, whose contours merge or break at any level
  double platform_min_area_px{150.0};  ///< smallest top (px^2) taken as a quadrilateral
  int platform_max_quads{3};           ///< at most this many quadrilaterals a frame, largest first
  // ---- ring identities checked on the sets' radial profiles (issue 12: no wrong pose) ----
  bool rotation_check{true};           ///< every pose: the outer sets' radial profiles in the
                                       ///< frame (angle-averaged about each predicted centre)
                                       ///< must fit the pose's own identities better than every
                                       ///< turn of the layout onto itself (60-300 deg), else no
                                       ///< pose: identities read wrongly in a yaw-smeared frame
                                       ///< turn the pose by 60-180 deg and pass every other gate
  double rotation_check_margin{0.02};  ///< by at least this (normalised cross-correlation; the
                                       ///< right identities lead by 0.033 or more on the full
                                       ///< sweep's rendered views, turned ones trailed by 0.08
                                       ///< or more on exactly drawn yaw-smeared frames)
  // ---- rolling shutter (issue 54) ----
  bool rolling_shutter_row_time{true};   ///< with a rolling shutter (the frame's readout_s > 0),
                                     ///< the flight stack stamps a pose at the mid-exposure of
                                     ///< the image row of the platform's centre instead of the
                                     ///< middle row's (up to half the readout earlier or later)
  // ---- blur (issue 12): the motion blur the caller predicts for the frame ----
  bool predict_blur{true};           ///< the flight stack predicts each frame's blur from its
                                     ///< own motion estimate and the exposure time and hands it
                                     ///< to the detector (FlightStack::predicted_blur_px)
  bool predict_min_depth{true};      ///< the flight stack hands the detector the least depth
                                     ///< the target's plane can be at in each frame, from its
                                     ///< fused height and attitude (FlightStack::
                                     ///< min_target_depth_m): without a pose or a track the code
                                     ///< map is not searched where its cells would be under
                                     ///< code_min_cell_px at that depth (above ~2 m)
  double deblur_min_px{4.0};         ///< a predicted blur at least this long (px) gives a frame
                                     ///< with no pose a second pass on the frame Wiener-
                                     ///< deconvolved with that blur (a line PSF); 0 = never.
                                     ///< Below ~4 px the plain passes already hold
  double deblur_noise_ratio{0.005};  ///< Wiener constant K (noise-to-signal power): the
                                     ///< deconvolution is G conj(H) / (|H|^2 + K); 0.005 found
                                     ///< the rings in 6 of 8 missed 12 px views, 0.02 in 3,
                                     ///< 0.05 in none
  int refine_max_iter{30};           ///< Levenberg-Marquardt iteration cap
  int refine_points_per_ellipse{24};  ///< edge points per ellipse in the conic cost
  double max_reproj_err_px{2.0};     ///< eq. 30 RMS above this rejects the frame (px)
  double max_edge_residual_px{1.5};  ///< conic-cost RMS above this rejects the frame (px)
  /// Both gates above also grow with the ring sets' extent in the image: each is the larger of
  /// its absolute value and this fraction of the extent (the RMS distance of the outer
  /// circles' points from the centres' centroid). A calibration that is off by a fraction
  /// of the focal length in one axis leaves residuals in proportion to that extent, largest
  /// in the last metre; 0 keeps the absolute gates alone.
  double max_reproj_fraction{0.012};

  // ---- keyframes (eq. 17-18) ----
  double rho_max{1e-3};              ///< reliability threshold on rho (dimensionless): about a
                                     ///< 4.5 % change of the unit pose vector (rho ~ dI^2 / 2)
  int keyframe_reset_after{5};       ///< after this many consecutive rejections, restart

  // ---- tracking ----
  bool tracking{true};               ///< search a predicted region first; the last pose also
                                     ///< gives a lone central pair its yaw and may skip the
                                     ///< code search (off: every frame stands alone)
  double roi_margin{0.35};           ///< ROI grows by this fraction of its size on each side
  int max_frames_without_detection{3};  ///< drop the prediction after this many misses

  // ---- code pattern (seed 001; vision_code.h) ----
  bool code_enabled{true};           ///< localise on the code map when its cells are in view
  double code_min_cell_px{8.0};      ///< smallest code cell side read (px): below ~8 px the
                                     ///< thresholded cell corners round off by a third
  int code_threshold_block_px{301};  ///< adaptive threshold window (px), odd: three cells at
                                     ///< touchdown (~100 px cells); a window near one cell
                                     ///< leaves the inside of large dark blobs light
  double code_threshold_offset{10.0};  ///< grey levels below the local mean counted dark
  double code_min_contrast{40.0};    ///< dark/light cell class means must differ by this (grey)
  double code_max_mismatch_fraction{0.03};  ///< disagreeing read cells allowed (fraction)
  int code_min_score_margin{8};      ///< runner-up placement must score this much lower
                                     ///< (a disagreement costs 4, an agreement gains 1)
  int code_min_corners{8};           ///< matched sub-pixel corners needed for the PnP
  double code_max_reproj_px{1.0};    ///< corner reprojection RMS gate after refinement (px)
  /// The gate also grows with the code's size in the image: the larger of code_max_reproj_px
  /// and this fraction of the corners' RMS distance from their centroid (px). A camera whose
  /// pixel aspect differs from its calibration by delta leaves about delta / 2 x that spread of
  /// RMS that no pose explains (1.0-1.5 px at 0.85 % and 0.2-0.4 m, 1.4-3.5 px at 2 %), while the
  /// identity is certain (hundreds of read cells agree with the map). 0.012 holds up to ~2.4 %,
  /// as the ring gates (max_reproj_fraction); 0 keeps the absolute gate alone.
  double code_max_reproj_fraction{0.012};
  /// With a pose (the rings' or the track's) that puts every code cell at least this big
  /// (px), the grid's corners and sides (step 1) are found on the frame halved (a quarter of
  /// the pixels to threshold and trace); the cells are read and the corners refined on the
  /// whole frame as always. 0 = step 1 always at full resolution.
  double code_half_res_min_cell_px{24.0};
  bool code_local_white{true};       ///< when one level for all cells gives no placement, read
                                     ///< each cell against its local white (shadows)
  bool code_search_region{true};     ///< with a pose (this frame's rings or the track), search
                                     ///< the code only around its projection (else, or when a
                                     ///< tracked region misses it, the whole frame)
  /// Close range: when the predicted region gave no pose and the track shows no ring set wholly
  /// in the frame (none can be identified: a set cut by the frame's edge gives no pair of whole
  /// ellipses), search the code map first and run the rings' full-frame passes only when it
  /// gives no pose. Also, with a track under which the code's cells are readable, when the whole
  /// frame's global segmentation gives no pose: the code map before the shadow pass and the
  /// later ring passes, which run only when it gives none. Off: the passes always run first
  /// (the same poses where a cut set is still identified, at ~2x the cost of a close-range
  /// frame).
  bool code_first_close_range{true};
  bool code_lattice_from_pose{true}; ///< with that pose, take the grid's two line families
                                     ///< from its predicted vanishing points (else from the
                                     ///< area's dominant side direction)

  // ---- fewer-ring poses and combination ----
  bool centre_ring_pose{true};       ///< pose from the central set (both circles) when fewer
                                     ///< than min_rings sets are identified
  double tracked_yaw_sigma_rad{0.05};  ///< yaw prior taken from the tracked pose (rad)
  double tracked_max_jump_m{0.1};      ///< a central pair alone, with the track's yaw, must lie
  double tracked_max_jump_ratio{0.2};  ///< within this + ratio x the tracked range of the
                                       ///< tracked pose (at most max_frames_without_detection
                                       ///< + 1 frames old: at 30 fps and 1 m, 2 m/s of
                                       ///< relative speed; a set taken for the central one
                                       ///< reads the range 30 % off or more)
  double combine_max_angle_rad{0.05};  ///< ring and code poses must agree this well (rad)
  double combine_max_offset_ratio{0.03};  ///< ... and to this fraction of the distance

  void validate() const;
};

// VisionParams' keys: segmentation, ellipse fitting, the shadow pass, ring identities.
template <class V>
void visit_segmentation_fields(V& v, VisionParams& p) {
  v("gaussian_sigma_px", p.gaussian_sigma_px, range::closed(0, 10), "px",
    "Gaussian pre-filter sigma");
  v("adaptive_threshold", p.adaptive_threshold, range::any, "",
    "local (adaptive mean) threshold instead of global Otsu");
  v("adaptive_block_px", p.adaptive_block_px, range::any, "px", "adaptive threshold window side");
  v("adaptive_offset", p.adaptive_offset, range::any, "",
    "adaptive threshold offset below the local mean");
  v("canny_edges", p.canny_edges, range::any, "",
    "Canny + close on the binary image before contours");
  v("close_kernel_px", p.close_kernel_px, range::closed(1, 15), "px",
    "morphological close kernel side");
  v("min_contour_points", p.min_contour_points, range::at_least(6).because("an ellipse needs 5"), "px",
    "contours shorter than this are ignored");
  v("min_axis_px", p.min_axis_px, range::positive, "px", "smallest accepted ellipse semi-axis");
  v("min_axis_ratio", p.min_axis_ratio, range::open(0, 1), "",
    "minor/major semi-axis ratio floor (about 81 deg tilt)");
  v("max_contour_fit_rms_px", p.max_contour_fit_rms_px, range::positive, "px",
    "pixel-contour ellipse fit RMS gate");
  v("edge_samples", p.edge_samples, range::closed(12, 1024), "",
    "edge points sampled around each ellipse");
  v("edge_search_px", p.edge_search_px, range::closed(1, 20), "px",
    "half length of the normal profile searched");
  v("refine_iterations", p.refine_iterations, range::closed(1, 10), "",
    "resample-and-refit passes");
  v("max_edge_fit_rms_px", p.max_edge_fit_rms_px, range::positive, "px",
    "sub-pixel edge fit RMS gate");
  v("edge_blur_sigma_px", p.edge_blur_sigma_px, range::closed(0, 10), "px",
    "camera blur (optics, defocus) sigma beyond the pixel box");
  v("guided_inner_search", p.guided_inner_search, range::any, "",
    "look for a missing inner circle at each model ratio");
  v("shadow_pass", p.shadow_pass, range::any, "", "shadow pass: segment again at shadow_levels");
  v("shadow_levels", p.shadow_levels, range::any, "", "threshold levels of the shadow pass");
  v("shadow_split_ratio", p.shadow_split_ratio, range::greater_than(1), "",
    "shadow pass: around one ellipse");
  v("max_centre_offset_ratio", p.max_centre_offset_ratio, range::positive, "",
    "|c_outer - c_inner| / inner minor axis");
  v("harmonic_tol_px", p.harmonic_tol_px, range::positive, "px",
    "harmonic-ratio recursion stops below this step");
  v("harmonic_max_iter", p.harmonic_max_iter, range::at_least(2), "",
    "harmonic-ratio recursion iteration cap");
  v("ratio_tol", p.ratio_tol, range::open(0, 0.5), "",
    "|r/R measured - r/R model| for a ring identity");
  v("min_rings", p.min_rings, range::at_least(4).because("planar PnP needs four points"), "",
    "identified centres needed for a pose (planar PnP)");
  v("three_ring_pose", p.three_ring_pose, range::any, "", "P3P pose from exactly three identified sets");
  v("max_centre_reproj_px", p.max_centre_reproj_px, range::positive, "px",
    "centre outlier gate after the initial PnP");
  v("max_centre_reproj_fraction", p.max_centre_reproj_fraction, range::closed(0, 0.1), "",
    "The centre gate also grows with the ring sets' extent in the image");
}

// ... the fallback passes (unfiltered, layout, zoom, platform), the rotation check, blur.
template <class V>
void visit_fallback_passes_fields(V& v, VisionParams& p) {
  v("unfiltered_pass", p.unfiltered_pass, range::any, "", "unfiltered pass: search again without the pre-filter");
  v("unfiltered_max_minor_px", p.unfiltered_max_minor_px, range::positive, "px",
    "an ellipse counts as small below this minor semi-axis");
  v("unfiltered_min_ellipses", p.unfiltered_min_ellipses, range::non_negative, "",
    "small ellipses needed to try the pass");
  v("layout_identification", p.layout_identification, range::any, "",
    "identify sets by the hexagon layout");
  v("layout_ratio_tol", p.layout_ratio_tol, range::open(0, 0.5), "", "mean |ratio - model| of a layout identification");
  v("layout_max_ratio_bias", p.layout_max_ratio_bias, range::closed_open(0, 0.5), "",
    "largest common ratio bias a layout removes");
  v("layout_ratio_margin", p.layout_ratio_margin, range::non_negative, "",
    "another identity whose mean ratio error is within this of the best");
  v("layout_min_ratio_sets", p.layout_min_ratio_sets, range::at_least(1).because("the ratios decide the rotation"), "",
    "measured ratios (inner circles found) needed");
  v("layout_position_tol", p.layout_position_tol, range::open(0, 0.5).because("neighbouring sets are one hexagon radius apart"), "",
    "a set's rectified centre within this fraction of its distance");
  v("layout_photometric_max_minor_px", p.layout_photometric_max_minor_px, range::closed(0, 64), "px",
    "a candidate whose minor semi-axis is at most this gives the layout");
  v("layout_size_tol", p.layout_size_tol, range::open_closed(0, 1), "",
    "rectified outer circle within a factor 1 + this of the model's");
  v("zoom_pass", p.zoom_pass, range::any, "", "zoom pass: search small candidates upscaled");
  v("zoom_max_axis_px", p.zoom_max_axis_px, range::positive, "px",
    "ellipses up to this semi-major axis seed a region");
  v("zoom_max_region_px", p.zoom_max_region_px, range::closed(16, 2048), "px",
    "regions larger than this (px, either side) are skipped");
  v("zoom_max_regions", p.zoom_max_regions, range::closed(0, 16), "",
    "at most this many regions a frame");
  v("platform_pass", p.platform_pass, range::any, "", "platform pass: search the platform's square outline");
  v("platform_min_area_px", p.platform_min_area_px, range::at_least(16), "px",
    "smallest top taken as a quadrilateral");
  v("platform_max_quads", p.platform_max_quads, range::closed(0, 16), "",
    "at most this many quadrilaterals a frame");
  v("rotation_check", p.rotation_check, range::any, "",
    "every pose: the outer sets' radial profiles in the frame must fit");
  v("rotation_check_margin", p.rotation_check_margin, range::closed_open(0, 1), "",
    "by at least this");
  v("rolling_shutter_row_time", p.rolling_shutter_row_time, range::any, "",
    "with a rolling shutter, a pose is stamped at its platform centre's row");
  v("predict_blur", p.predict_blur, range::any, "",
    "the flight stack predicts each frame's blur from its own motion");
  v("predict_min_depth", p.predict_min_depth, range::any, "",
    "the flight stack hands the detector the least depth the target's plane can be at");
  v("deblur_min_px", p.deblur_min_px, range::closed(0, 200), "px",
    "a predicted blur at least this long gives a frame with no pose");
  v("deblur_noise_ratio", p.deblur_noise_ratio, range::open_closed(0, 1), "",
    "Wiener constant K (noise-to-signal power)");
}

// ... pose refinement and gates, tracking, the code map, combining poses.
template <class V>
void visit_pose_and_code_fields(V& v, VisionParams& p) {
  v("refine_max_iter", p.refine_max_iter, range::non_negative, "",
    "Levenberg-Marquardt iteration cap");
  v("refine_points_per_ellipse", p.refine_points_per_ellipse, range::at_least(6), "",
    "edge points per ellipse in the conic cost");
  v("max_reproj_err_px", p.max_reproj_err_px, range::positive, "px",
    "eq. 30 RMS above this rejects the frame");
  v("max_edge_residual_px", p.max_edge_residual_px, range::positive, "px",
    "conic-cost RMS above this rejects the frame");
  v("max_reproj_fraction", p.max_reproj_fraction, range::closed(0, 0.05), "",
    "Both gates above also grow with the ring sets' extent in the image");
  v("rho_max", p.rho_max, range::open_closed(0, 1), "",
    "reliability threshold on rho (dimensionless)");
  v("keyframe_reset_after", p.keyframe_reset_after, range::non_negative, "",
    "after this many consecutive rejections");
  v("tracking", p.tracking, range::any, "", "search a predicted region first");
  v("roi_margin", p.roi_margin, range::non_negative, "",
    "ROI grows by this fraction of its size on each side");
  v("max_frames_without_detection", p.max_frames_without_detection, range::non_negative, "",
    "drop the prediction after this many misses");
  v("code_enabled", p.code_enabled, range::any, "",
    "localise on the code map when its cells are in view");
  v("code_min_cell_px", p.code_min_cell_px, range::at_least(4), "px",
    "smallest code cell side read");
  v("code_threshold_block_px", p.code_threshold_block_px, range::any, "px",
    "adaptive threshold window");
  v("code_threshold_offset", p.code_threshold_offset, range::non_negative, "",
    "grey levels below the local mean counted dark");
  v("code_min_contrast", p.code_min_contrast, range::positive, "",
    "dark/light cell class means must differ by this");
  v("code_max_mismatch_fraction", p.code_max_mismatch_fraction, range::closed_open(0, 0.2), "",
    "disagreeing read cells allowed");
  v("code_min_score_margin", p.code_min_score_margin, range::at_least(1), "",
    "runner-up placement must score this much lower");
  v("code_min_corners", p.code_min_corners, range::at_least(4).because("planar PnP"), "",
    "matched sub-pixel corners needed for the PnP");
  v("code_max_reproj_px", p.code_max_reproj_px, range::positive, "px",
    "corner reprojection RMS gate after refinement");
  v("code_half_res_min_cell_px", p.code_half_res_min_cell_px, range::non_negative, "px",
    "with a pose putting every code cell at least this big, the grid's features are found "
    "at half resolution (0 = never)");
  v("code_max_reproj_fraction", p.code_max_reproj_fraction, range::closed(0, 0.02), "",
    "The gate also grows with the code's size in the image");
  v("code_local_white", p.code_local_white, range::any, "",
    "code map: local white levels per cell");
  v("code_search_region", p.code_search_region, range::any, "",
    "code map: search where the pose puts it");
  v("code_first_close_range", p.code_first_close_range, range::any, "",
    "close range: the code map before the rings' full-frame passes");
  v("code_lattice_from_pose", p.code_lattice_from_pose, range::any, "",
    "code map: grid lines from the pose");
  v("centre_ring_pose", p.centre_ring_pose, range::any, "",
    "pose from the central set when fewer than min_rings sets");
  v("tracked_yaw_sigma_rad", p.tracked_yaw_sigma_rad, range::positive, "rad",
    "yaw prior taken from the tracked pose");
  v("tracked_max_jump_m", p.tracked_max_jump_m, range::non_negative, "m", "largest jump of a central-pair pose from the track");
  v("tracked_max_jump_ratio", p.tracked_max_jump_ratio, range::non_negative, "",
    "within this + ratio x the tracked range of the tracked pose");
  v("combine_max_angle_rad", p.combine_max_angle_rad, range::positive, "rad",
    "ring and code poses must agree this well");
  v("combine_max_offset_ratio", p.combine_max_offset_ratio, range::positive, "",
    "... and to this fraction of the distance");
}

template <class V>
void visit_fields(V& v, VisionParams& p) {
  visit_segmentation_fields(v, p);
  visit_fallback_passes_fields(v, p);
  visit_pose_and_code_fields(v, p);
}

}  // namespace lander
