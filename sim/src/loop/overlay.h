// Small helpers shared by the scripted and closed-loop runs (private to sim/): video overlay
// text, roll-pitch-yaw for traces, the chase camera. Text is formatted with fmt::format.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>
#include <fmt/format.h>
#include <mujoco/mujoco.h>
#include <opencv2/imgproc.hpp>

#include "lander/core/types.h"
#include "lander/sim/scenario.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {

// ZYX angles (roll, pitch, yaw) of R = Rz(yaw) Ry(pitch) Rx(roll).
inline Eigen::Vector3d rpy_of(const Eigen::Matrix3d& R) { return rpy_from_R(R); }

// White text with a dark outline on line `line` of a video frame.
inline void put_text(cv::Mat& img, const std::string& text, int line) {
  const cv::Point org(10, 22 + 20 * line);
  cv::putText(img, text, org, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(img, text, org, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
}

// A chase camera behind and above the vehicle: a free camera whose look-at point is the
// vehicle, so the vehicle stays at the centre of the view.
inline mjvCamera chase_camera(const World& w, const VideoParams& vp) {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FREE;
  const Eigen::Vector3d p = w.X_WB().translation();
  for (int i = 0; i < 3; ++i) cam.lookat[i] = p[i];
  cam.distance = vp.chase_distance_m;
  cam.elevation = -30;
  cam.azimuth = 200;
  return cam;
}

}  // namespace lander::sim
