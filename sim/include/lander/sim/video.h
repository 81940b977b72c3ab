// MP4 (H.264) writer: pipes raw BGR frames to the ffmpeg command-line tool.
#pragma once

#include <cstdio>
#include <string>

#include <opencv2/core.hpp>

namespace lander::sim {

class VideoWriter {
 public:
  // Starts ffmpeg writing `path` at `fps`; frames must be width x height CV_8UC3. Throws
  // std::runtime_error if ffmpeg is not on PATH or cannot start.
  VideoWriter(const std::string& path, int width, int height, double fps);
  ~VideoWriter();  // closes (finishes the file)
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  void write(const cv::Mat& bgr);
  // Finishes the file; throws if ffmpeg reported an error. Idempotent.
  void close();
  int frames() const { return frames_; }

 private:
  std::string path_;
  int width_, height_;
  FILE* pipe_ = nullptr;
  int frames_ = 0;
};

// True if an executable named `name` is on PATH.
bool on_path(const std::string& name);

}  // namespace lander::sim
