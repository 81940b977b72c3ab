// make_texture: writes the landing-target texture PNG that tools/probe/probe_render.py
// samples, using the project's own code (TargetGeometry::load + render_target_texture), so the
// probe's images show exactly the texture the detector expects.
//
// Build (from the repository root, after `cmake -S . -B build && cmake --build build`):
//   g++ -O2 -std=c++17 tools/probe/make_texture.cpp -o build/make_texture -I estimator/include -I /usr/include/eigen3 -I /usr/include/opencv4 build/estimator/liblander_estimator.a -lyaml-cpp -lopencv_imgcodecs -lopencv_core
// (the minimal set: the estimator's target.cpp needs yaml-cpp and opencv_core, imwrite needs
// opencv_imgcodecs; Eigen is header-only; Ceres, glog and the other OpenCV modules are not needed.)
//
// Run:
//   build/make_texture models/target.yaml OUT.png
// (the probe's default texture path is <out>/texture.png, see tools/probe/README.md).
// It also prints texture_to_platform() for the corner and centre texels as a convention check.
#include <cstdio>
#include <exception>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "lander/estimator/target.h"

static void usage(const char* prog) {
  std::fprintf(stderr,
               "usage: %s TARGET.yaml OUT.png\n"
               "  Renders the target texture described by TARGET.yaml (e.g. models/target.yaml)\n"
               "  with lander::render_target_texture and writes it to OUT.png.\n",
               prog);
}

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      usage(argv[0]);
      return 0;
    }
  }
  if (argc != 3) {
    usage(argv[0]);
    return 2;
  }
  try {
    auto g = lander::TargetGeometry::load(argv[1]);
    cv::Mat t = lander::render_target_texture(g);
    if (!cv::imwrite(argv[2], t)) {
      std::fprintf(stderr, "make_texture: could not write %s\n", argv[2]);
      return 1;
    }
    // print mapping checks
    double us[4][2] = {{0, 0}, {4095, 0}, {0, 4095}, {2047.5, 2047.5}};
    for (auto& uv : us) {
      auto p = lander::texture_to_platform(g, uv[0], uv[1]);
      std::printf("tex (%.1f,%.1f) -> P (%.6f, %.6f)\n", uv[0], uv[1], p.x(), p.y());
    }
    std::printf("px_per_m %.6f size %d\n", g.px_per_m(), g.texture_px);
    std::printf("wrote %s\n", argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_texture: %s\n", e.what());
    return 1;
  }
  return 0;
}
