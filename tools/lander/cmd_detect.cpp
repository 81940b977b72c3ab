// `lander detect IMAGE --camera CALIB.yaml [--target TARGET.yaml] [--params VISION.yaml]
// [--blur-px DX,DY] [--json]`: runs the ring-target pose estimator (seed 000 section 2) on one
// image file; --blur-px is the motion blur over the exposure (px), when known.
// Exit codes: 0 when the image was processed (detected or not: see "detected"/"reason"),
// 2 for bad input (missing or unreadable file, bad YAML, image size not the calibration's).
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "lander/estimator/vision_detector.h"

namespace lander::cli {
namespace {

int run_detect(const Args& args) {
  const ArgParser ap(args, {"camera", "target", "params", "blur-px"}, {"json"});
  if (ap.positional().size() != 1) {
    throw UsageError("usage: lander detect IMAGE --camera CALIB.yaml [--target TARGET.yaml] "
                     "[--params VISION.yaml] [--blur-px DX,DY] [--json]");
  }
  if (!ap.has("camera")) throw UsageError("--camera CALIB.yaml is required");
  const std::string image_path = ap.positional()[0];
  const std::string target_path = ap.value("target", models_dir() + "/target.yaml");
  for (const auto& p : {image_path, ap.value("camera"), target_path}) {
    if (!std::filesystem::is_regular_file(p)) throw ConfigError("no such file: " + p);
  }
  const CameraModel camera = load_camera_model(ap.value("camera"));
  const TargetGeometry target = TargetGeometry::load(target_path);
  VisionParams params;
  if (ap.has("params")) read_params(load_yaml_file(ap.value("params")), ap.value("params"), params);
  params.tracking = false;

  const cv::Mat image = cv::imread(image_path, cv::IMREAD_COLOR);
  if (image.empty()) throw ConfigError("cannot read image (not a PNG/JPG?): " + image_path);
  if (image.cols != camera.width_px || image.rows != camera.height_px) {
    throw ConfigError("image " + image_path + " is " + std::to_string(image.cols) + "x" +
                      std::to_string(image.rows) + " but the calibration " + ap.value("camera") +
                      " is " + std::to_string(camera.width_px) + "x" +
                      std::to_string(camera.height_px));
  }
  Eigen::Vector2d blur = Eigen::Vector2d::Zero();
  if (ap.has("blur-px")) {
    const std::vector<double> b =
        ap.numbers("blur-px", {}, -std::numeric_limits<double>::infinity());
    if (b.size() != 2) throw UsageError("--blur-px takes two numbers: DX,DY (px)");
    blur = Eigen::Vector2d(b[0], b[1]);
  }
  const RingDetection d = detect_ring_target(image, camera, target, params, blur);
  if (ap.flag("json")) {
    std::cout << to_json(d) << "\n";
    return kExitOk;
  }
  std::cout << std::fixed << std::setprecision(4);
  std::cout << image_path << ": " << (d.detected ? "detected" : "not detected") << " ("
            << to_string(d.status) << ": " << d.reason << "), " << d.time_ms << " ms\n";
  if (d.detected) {
    const Eigen::Vector3d p = d.X_CP.translation();
    const Eigen::Quaterniond q(d.X_CP.linear());
    std::cout << "  p_CP_m     " << p.x() << " " << p.y() << " " << p.z() << "\n"
              << "  q_CP_wxyz  " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << "\n"
              << "  reproj_err " << d.reproj_err_px << " px (eq. 30 RMS; gate " << d.reproj_gate_px
              << " px), conic residual " << d.edge_rms_px << " px (gate " << d.edge_gate_px << " px)\n";
  }
  for (const auto& c : d.centres) {
    std::cout << "  ring " << c.ring_id << " centre " << c.centre_image_px.x() << " "
              << c.centre_image_px.y() << " px, r/R " << c.radius_ratio << "\n";
  }
  return kExitOk;
}

const LanderCommand kDetect("detect",
                            "IMAGE --camera CALIB.yaml [--target T.yaml] [--params P.yaml] "
                            "[--blur-px DX,DY] [--json]: ring-target pose from one image",
                            Kind::Command, run_detect);

}  // namespace
}  // namespace lander::cli
