// Internal to lander_bench: the camera condition of `lander bench estimator` (issue 54).
//
// The same views, each with the camera moving over the platform (camera_speed_mps in a random
// direction parallel to it, camera_rate_dps about a random axis), seen through four cameras:
//   global                 a global shutter exposing every row at the frame's middle instant;
//   jpeg                   the same frame after a JPEG round trip (camera_jpeg_quality, 4:2:0);
//   rolling_shutter        row v exposed readout x (v / rows - 1/2) after the middle instant,
//                          the frame built from camera_bands bands, each rendered at its centre
//                          row's time;
//   rolling_shutter+jpeg   both: the seed's camera (Table 2: CMOS, JPG over USB).
// Every method (ours, AprilTag, ArUco, ArUco + subpix) runs on each. A pose is scored against
// the truth at the frame's middle instant (`in_view`: what a flight software that stamps the
// frame at its middle sees) and against the truth at the time of the row its platform centre
// was read (`in_view_row_time`: estimator.vision.rolling_shutter_row_time, the same rule for
// every method); detected points against their true projections at their own row's time.
#pragma once

#include <iosfwd>

#include <Eigen/Geometry>

#include "bench_metrics.h"
#include "lander/bench/estimator_bench.h"

namespace lander::bench::detail {

// Runs the camera condition; returns its JSON object (`config`, `conditions`). `progress`, if
// given, receives a line per altitude and the console table.
Json run_camera_condition(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP,
                          const TargetGeometry& g, const CameraModel& cam, const VisionParams& vision,
                          const EstimatorBenchParams& p, std::ostream* progress);

}  // namespace lander::bench::detail
