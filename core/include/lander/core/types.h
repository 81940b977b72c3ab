// What the flight software sees: timestamped sensor samples, camera calibration and mount.
// These are the only inputs the estimator and controller get from the vehicle (or the
// simulator); ground truth never appears here. Frames and names follow docs/design/architecture.md:
// X_AB is the pose of frame B in frame A; W world (z up), B body (x fwd, y left, z up),
// C camera (OpenCV: x right, y down, z optical axis), P platform (z out of the top).
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/params_io.h"

namespace lander {

// Roll-pitch-yaw (rad) -> R = Rz(yaw) Ry(pitch) Rx(roll): the z-y-x convention of every
// rpy_* key and trace column.
Eigen::Matrix3d R_from_rpy(const Eigen::Vector3d& rpy_rad);
// The inverse: (roll, pitch, yaw) of R in the same convention, pitch in [-pi/2, pi/2].
Eigen::Vector3d rpy_from_R(const Eigen::Matrix3d& R);

// Pinhole camera with Brown-Conrady distortion (OpenCV's model and pixel convention: the
// centre of the top-left pixel is (0, 0)).
struct CameraModel {
  int width_px{1280};    ///< image width (px), > 0
  int height_px{720};    ///< image height (px), > 0
  double fx_px{640.0};   ///< focal length along x (px); 2.8 mm lens of seed 000
  double fy_px{640.0};   ///< focal length along y (px)
  double cx_px{639.5};   ///< principal point x (px), image centre in OpenCV convention
  double cy_px{359.5};   ///< principal point y (px)
  double k1{0.0}, k2{0.0}, p1{0.0}, p2{0.0}, k3{0.0};  ///< Brown-Conrady coefficients

  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx_px, 0, cx_px, 0, fy_px, cy_px, 0, 0, 1;
    return k;
  }
  bool has_distortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  // Raw-image pixel of an undistorted pixel u (applies the Brown-Conrady model; identity
  // without distortion).
  Eigen::Vector2d distort_px(const Eigen::Vector2d& u) const;
  void validate() const {
    check_fields(*this);
  }
};

template <class V>
void visit_fields(V& v, CameraModel& p) {
  v("width_px", p.width_px, range::positive, "px", "image width");
  v("height_px", p.height_px, range::positive, "px", "image height");
  v("fx_px", p.fx_px, range::positive, "px", "focal length along x");
  v("fy_px", p.fy_px, range::positive, "px", "focal length along y");
  v("cx_px", p.cx_px, range::any, "px", "principal point x");
  v("cy_px", p.cy_px, range::any, "px", "principal point y");
  v("k1", p.k1, range::any, "", "Brown-Conrady coefficients");
  v("k2", p.k2, range::any, "", "Brown-Conrady coefficients");
  v("p1", p.p1, range::any, "", "Brown-Conrady coefficients");
  v("p2", p.p2, range::any, "", "Brown-Conrady coefficients");
  v("k3", p.k3, range::any, "", "Brown-Conrady coefficients");
}

// Rigid mount of the camera on the body: X_BC. Default: under the centre of mass, looking
// straight down, image top towards the body's nose (camera x = -body y, camera y = -body x).
struct CameraMount {
  Eigen::Vector3d p_BC_m{0.0, 0.0, -0.08};  ///< camera origin in B (m)
  Eigen::Vector3d rpy_BC_deg{180.0, 0.0, -90.0};  ///< R_BC as roll-pitch-yaw (deg)
  Eigen::Isometry3d X_BC() const;
  void validate() const {}
};

template <class V>
void visit_fields(V& v, CameraMount& p) {
  v("p_BC_m", p.p_BC_m, range::any, "m", "camera origin in B");
  v("rpy_BC_deg", p.rpy_BC_deg, range::any, "deg", "R_BC as roll-pitch-yaw");
}

// One camera frame as the vehicle delivers it: BGR 8-bit image plus its exposure interval.
// (The cv::Mat lives in the estimator's vision headers; here only the timing.)
// A frame's exposure: from the first row's start to the last row's end. With a rolling
// shutter (readout_s > 0) row v of H is exposed over [t_start + readout v / H, ... + the row's
// exposure]; mid() is then the middle row's mid-exposure, row_exposure_s() each row's own.
struct ExposureInterval {
  double t_start_s{0.0};  ///< exposure start of the first row (s, sim time)
  double t_end_s{0.0};    ///< exposure end of the last row (s, sim time)
  double readout_s{0.0};  ///< first row's start to the last row's start (0 = global shutter)
  double mid() const { return 0.5 * (t_start_s + t_end_s); }
  double row_exposure_s() const { return t_end_s - t_start_s - readout_s; }
};

// IMU sample: body rates and specific force (accelerometer reading, includes -g), in B.
struct ImuSample {
  double t_s{0.0};
  Eigen::Vector3d gyro_B_radps{Eigen::Vector3d::Zero()};
  Eigen::Vector3d accel_B_mps2{Eigen::Vector3d::Zero()};  ///< specific force (m/s^2)
};

// Barometer: static pressure; altitude via the ISA model (seed 004 eq. 8) in the estimator.
struct BaroSample {
  double t_s{0.0};
  double pressure_pa{101325.0};
};

// GPS fix already in the local world frame W (metres from the start point, z up).
struct GpsSample {
  double t_s{0.0};
  bool valid{true};  ///< false during a drop-out (no fix)
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};
};

// Magnetometer: the local magnetic field in B (microtesla), hard-iron bias included.
struct MagSample {
  double t_s{0.0};
  Eigen::Vector3d field_B_uT{Eigen::Vector3d::Zero()};
};

// Ultrasonic range straight down along -z of B. Outside 0.15-3.05 m the reading is garbage
// (seed 004 eq. 12); the sensor does not flag it.
struct UltrasonicSample {
  double t_s{0.0};
  double range_m{0.0};
};

}  // namespace lander
