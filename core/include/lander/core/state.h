// Estimates that flow from the estimator to the controller. Built only from what the vehicle
// measures (types.h); never from ground truth.
#pragma once

#include <limits>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lander {

// Navigation solution (what seed 000 reads from its flight controller as R_b^n and t_b^n).
struct NavState {
  double t_s{0.0};
  bool valid{false};
  Eigen::Quaterniond q_WB{Eigen::Quaterniond::Identity()};  ///< attitude of B in W
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};            ///< position of B in W (m)
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};          ///< velocity of B in W (m/s)
  Eigen::Vector3d omega_B_radps{Eigen::Vector3d::Zero()};    ///< body rates, bias-corrected
  /// The sum of the steps the GPS corrections (and the velocity taken from a fix after a
  /// drop-out) have made in v_W_mps since the first fix, horizontal only (z is 0: the vertical
  /// comes from the altitude fusion). Between two states its change is the correction made
  /// in between: the part of v_W_mps's change that is not the vehicle's acceleration. The
  /// platform tracker moves its dead-reckoned history by it (PlatformTracker::add_nav).
  Eigen::Vector3d v_corr_W_mps{Eigen::Vector3d::Zero()};
};

// Fused altitude (seed 004 section 4): height of B in W and above the surface below.
struct AltitudeEstimate {
  double t_s{0.0};
  bool valid{false};
  double z_W_m{0.0};             ///< height of B above the W origin plane (m)
  double vz_W_mps{0.0};          ///< vertical velocity (m/s)
  double h_surface_m{0.0};       ///< height of B above the surface below it (m)
  double baro_bias_m{0.0};       ///< estimated barometer bias (m)
  double var_m2{0.0};            ///< variance of z_W_m (m^2)
  /// Height of B above whatever the ultrasonic sees below, by the newest chain of
  /// clearance_count agreeing in-range readings, carried to t_s by the height's own motion;
  /// NaN when the last readings do not form such a chain (out of range, garbage). Unlike
  /// h_surface_m it does not depend on which surface the filter believes is below.
  double clearance_m{std::numeric_limits<double>::quiet_NaN()};
};

// One vision measurement of the platform, as the controller receives it (after latency).
struct PlatformObservation {
  double t_s{0.0};               ///< mid-exposure time of the frame (s)
  bool detected{false};
  bool keyframe{false};          ///< passed the keyframe test (seed 000 eq. 17-18)
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};  ///< platform pose in camera frame
  Eigen::Matrix<double, 6, 6> cov{Eigen::Matrix<double, 6, 6>::Identity()};  ///< [rot; trans]
  int rings_identified{0};
  double reproj_err_px{0.0};     ///< seed 000 eq. 30
};

}  // namespace lander
