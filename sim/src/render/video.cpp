#include "lander/sim/render/video.h"

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace lander::sim {

VideoWriter::VideoWriter(const std::string& path, int width, int height, double fps)
    : path_(path), width_(width), height_(height) {
  if (!on_path("ffmpeg")) {
    throw std::runtime_error("cannot write " + path + ": ffmpeg is not installed (apt-get install ffmpeg)");
  }
  if (width % 2 || height % 2) {
    throw std::runtime_error("cannot write " + path + ": H.264 needs even frame sizes");
  }
  // ffmpeg picks the container from the name: keep ".mp4" last in the temporary name.
  tmp_path_ = path + ".partial.mp4";
  const std::string rate = fmt::format("{:.6g}", fps);
  const std::vector<std::string> argv = {
      "ffmpeg", "-nostdin", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "bgr24",
      "-s", std::to_string(width) + "x" + std::to_string(height), "-r", rate, "-i", "pipe:0",
      "-an", "-c:v", "libx264", "-preset", "veryfast", "-crf", "23", "-pix_fmt", "yuv420p",
      "-movflags", "+faststart", "-f", "mp4",
      // "file:" keeps a name that starts with '-' or holds ':' a plain file name.
      "file:" + tmp_path_};
  SpawnOptions o;
  o.stdin_pipe = true;
  o.stdout_to_null = true;
  ffmpeg_ = std::make_unique<ChildProcess>(ChildProcess::spawn(argv, o));
}

VideoWriter::~VideoWriter() {
  if (!ffmpeg_) return;
  // Not closed: the run stopped on an error. Discard the partial file (the child is killed
  // and reaped by ChildProcess's destructor), as for every other output file.
  ffmpeg_.reset();
  std::remove(tmp_path_.c_str());
}

void VideoWriter::write(const cv::Mat& bgr) {
  if (!ffmpeg_) throw std::runtime_error("video " + path_ + " is closed");
  if (bgr.cols != width_ || bgr.rows != height_ || bgr.type() != CV_8UC3) {
    throw std::runtime_error("video " + path_ + ": frame size or type differs from the stream");
  }
  const cv::Mat c = bgr.isContinuous() ? bgr : bgr.clone();
  if (!ffmpeg_->write_stdin(c.data, c.total() * c.elemSize())) {
    throw std::runtime_error("video " + path_ + ": ffmpeg stopped accepting frames");
  }
  ++frames_;
}

void VideoWriter::close() {
  if (!ffmpeg_) return;
  ffmpeg_->close_stdin();
  const ExitStatus st = ffmpeg_->wait();
  ffmpeg_.reset();
  if (!st.ok()) {
    std::remove(tmp_path_.c_str());
    throw std::runtime_error("ffmpeg failed writing " + path_ + " (" + st.describe() + ")");
  }
  if (std::rename(tmp_path_.c_str(), path_.c_str()) != 0) {
    throw std::runtime_error("cannot rename " + tmp_path_ + " to " + path_);
  }
}

}  // namespace lander::sim
