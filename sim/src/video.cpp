#include "lander/sim/video.h"

#include <unistd.h>

#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace lander::sim {

bool on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream ss(path);
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (!dir.empty() && access((dir + "/" + name).c_str(), X_OK) == 0) return true;
  }
  return false;
}

VideoWriter::VideoWriter(const std::string& path, int width, int height, double fps)
    : path_(path), width_(width), height_(height) {
  if (!on_path("ffmpeg")) {
    throw std::runtime_error("cannot write " + path + ": ffmpeg is not installed (apt-get install ffmpeg)");
  }
  if (width % 2 || height % 2) {
    throw std::runtime_error("cannot write " + path + ": H.264 needs even frame sizes");
  }
  std::ostringstream cmd;
  cmd << "ffmpeg -loglevel error -y -f rawvideo -pix_fmt bgr24 -s " << width << "x" << height
      << " -r " << fps << " -i - -an -c:v libx264 -preset veryfast -crf 23 -pix_fmt yuv420p "
      << "-movflags +faststart '" << path << "'";
  pipe_ = popen(cmd.str().c_str(), "w");
  if (!pipe_) throw std::runtime_error("cannot start ffmpeg for " + path);
}

VideoWriter::~VideoWriter() {
  try {
    close();
  } catch (...) {
    // Destructors must not throw; close() explicitly to see errors.
  }
}

void VideoWriter::write(const cv::Mat& bgr) {
  if (!pipe_) throw std::runtime_error("video " + path_ + " is closed");
  if (bgr.cols != width_ || bgr.rows != height_ || bgr.type() != CV_8UC3) {
    throw std::runtime_error("video " + path_ + ": frame size or type differs from the stream");
  }
  const cv::Mat c = bgr.isContinuous() ? bgr : bgr.clone();
  const std::size_t n = c.total() * c.elemSize();
  if (std::fwrite(c.data, 1, n, pipe_) != n) {
    throw std::runtime_error("video " + path_ + ": ffmpeg stopped accepting frames");
  }
  ++frames_;
}

void VideoWriter::close() {
  if (!pipe_) return;
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status != 0) throw std::runtime_error("ffmpeg failed writing " + path_);
}

}  // namespace lander::sim
