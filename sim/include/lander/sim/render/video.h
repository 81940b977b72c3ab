// MP4 (H.264) writer: pipes raw BGR frames to the ffmpeg command-line tool, started from an
// argument vector (no shell: any byte may appear in the path). The file is written under a
// temporary name next to it and renamed when ffmpeg has finished it, so a run that stops
// midway never leaves a playable-looking half file.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "lander/sim/util/process.h"

namespace lander::sim {

class VideoWriter {
 public:
  // Starts ffmpeg writing `path` at `fps`; frames must be width x height CV_8UC3. Throws
  // std::runtime_error if ffmpeg is not on PATH or cannot start.
  VideoWriter(const std::string& path, int width, int height, double fps);
  ~VideoWriter();  // without close(): stops ffmpeg and removes the partial file
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  void write(const cv::Mat& bgr);
  // Finishes the file; throws if ffmpeg reported an error. Idempotent.
  void close();
  int frames() const { return frames_; }

 private:
  std::string path_;
  int width_, height_;
  std::string tmp_path_;
  std::unique_ptr<ChildProcess> ffmpeg_;
  int frames_ = 0;
};

}  // namespace lander::sim
