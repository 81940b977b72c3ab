// libFuzzer target: the target YAML (models/target.yaml's format) and the camera calibration
// YAML through their loaders; the first input byte picks which.
#include "fuzz_common.h"
#include "lander/estimator/target.h"
#include "lander/estimator/vision_detector.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path = lander::fuzz::write_input(data + 1, size - 1, ".yaml");
  lander::fuzz::expect_clean([&] {
    if (data[0] & 1) {
      const lander::TargetGeometry t = lander::TargetGeometry::load(path);
      (void)t;
    } else {
      const lander::CameraModel c = lander::load_camera_model(path);
      (void)c;
    }
  });
  return 0;
}
