// libFuzzer target: image bytes decoded (PNG, JPEG, BMP, ... as cv::imdecode reads them), then
// the ring detector on them with the default calibration scaled to the image. The detector
// must never throw on image content, and must never report a pose with a non-finite value.
#include <cmath>
#include <cstdlib>

#include <opencv2/imgcodecs.hpp>

#include "fuzz_common.h"
#include "lander/estimator/target.h"
#include "lander/estimator/vision_detector.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const lander::TargetGeometry target =
      lander::TargetGeometry::load(std::string(LANDER_MODELS_DIR) + "/target.yaml");
  const cv::Mat bytes(1, static_cast<int>(size), CV_8U, const_cast<uint8_t*>(data));
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    return 0;  // not an image: the decoder's business, not the detector's
  }
  // Bounded work per input: the camera's own size at most.
  if (image.empty() || image.cols > 1280 || image.rows > 720 || image.cols < 8 || image.rows < 8) return 0;
  lander::CameraModel cam;
  const double s = static_cast<double>(image.cols) / cam.width_px;
  cam.width_px = image.cols;
  cam.height_px = image.rows;
  cam.fx_px *= s;
  cam.fy_px *= s;
  cam.cx_px = (image.cols - 1) / 2.0;
  cam.cy_px = (image.rows - 1) / 2.0;
  lander::VisionParams params;
  params.tracking = false;
  lander::fuzz::expect_clean([&] {
    const lander::RingDetection d = lander::detect_ring_target(image, cam, target, params);
    if (d.detected && !d.X_CP.matrix().allFinite()) {
      std::fprintf(stderr, "fuzz: detected pose is not finite\n");
      std::abort();
    }
  });
  return 0;
}
