// JPEG delivery of a frame (issue 54): encoded with libjpeg through OpenCV at a quality (its
// default 4:2:0 chroma subsampling, what a UVC camera sends) and decoded again. Shared by the
// camera pipeline and the estimator benchmark's camera condition.
#pragma once

#include <cstddef>

#include <opencv2/core.hpp>

namespace lander::sim {

// The frame after a JPEG round trip at `quality` (1-100); `bytes`, if given, receives the
// encoded size. Throws std::runtime_error if encoding or decoding fails.
cv::Mat jpeg_round_trip(const cv::Mat& bgr, int quality, std::size_t* bytes = nullptr);

}  // namespace lander::sim
