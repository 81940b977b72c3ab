// The motion blur a camera's own motion puts into a frame (issue 12): what the flight
// software predicts from its navigation state and hands to the detector's blur-aware pass.
#pragma once

#include <Eigen/Core>

namespace lander {

// Image motion (px) over an exposure of `exposure_s` of the point on the optical axis at depth
// `depth_m`, for a pinhole camera (focal lengths fx, fy in px) turning at `w_C_radps` and
// moving at `v_C_mps` relative to the scene, both in the camera frame (x right, y down, z along
// the optical axis). A static point P moves in the camera frame as dP/dt = -v - w x P; at
// P = (0, 0, Z) the projection u = fx X / Z, v = fy Y / Z moves at
//   du/dt = -fx (w_y + v_x / Z),  dv/dt = fy (w_x - v_y / Z),
// which times the exposure time is the blur (first order: the motion during one exposure is
// small against the depth). Rotation about the optical axis does not move that point.
inline Eigen::Vector2d axis_point_motion_blur_px(const Eigen::Vector3d& w_C_radps, const Eigen::Vector3d& v_C_mps,
                                                 double depth_m, double fx_px, double fy_px, double exposure_s) {
  return exposure_s * Eigen::Vector2d(-fx_px * (w_C_radps.y() + v_C_mps.x() / depth_m),
                                      fy_px * (w_C_radps.x() - v_C_mps.y() / depth_m));
}

}  // namespace lander
