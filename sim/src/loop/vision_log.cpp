#include "lander/sim/loop/vision_log.h"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "lander/estimator/params_io.h"
#include "lander/sim/util/output_files.h"

namespace lander::sim {

namespace {
constexpr const char* kHeader =
    "frame,deliver_t_s,t_s,detected,keyframe,rings_identified,reproj_err_px,h_plane_m,"
    "R00,R01,R02,R10,R11,R12,R20,R21,R22,tx,ty,tz,cov[36]";
constexpr int kFields = 8 + 9 + 3 + 36;
}  // namespace

void write_vision_log(const std::string& path, const std::vector<VisionLogEntry>& log) {
  AtomicFile f(path);
  f.write(kHeader);
  f.write("\n");
  for (const VisionLogEntry& e : log) {
    const PlatformObservation& o = e.result.obs;
    std::string row = fmt::format("{},{:a},{:a},{},{},{},{:a},{:a}", e.frame, e.deliver_t_s, o.t_s,
                                  o.detected ? 1 : 0, o.keyframe ? 1 : 0, o.rings_identified,
                                  o.reproj_err_px, e.result.h_plane_m);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) row += fmt::format(",{:a}", o.X_CP.linear()(r, c));
    }
    for (int i = 0; i < 3; ++i) row += fmt::format(",{:a}", o.X_CP.translation()[i]);
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) row += fmt::format(",{:a}", o.cov(r, c));
    }
    f.write(row);
    f.write("\n");
  }
  f.commit();
}

std::vector<VisionLogEntry> read_vision_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open vision log");
  std::string line;
  std::getline(in, line);
  if (line != kHeader) throw ConfigError(path + ":1: not a vision log (unexpected header)");
  std::vector<VisionLogEntry> log;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) {
      errno = 0;
      char* end = nullptr;
      const double x = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || errno == ERANGE) {
        throw ConfigError(fmt::format("{}:{}: malformed number '{}'", path, line_no, cell));
      }
      v.push_back(x);
    }
    if (static_cast<int>(v.size()) != kFields) {
      throw ConfigError(fmt::format("{}:{}: {} fields, expected {}", path, line_no, v.size(), kFields));
    }
    VisionLogEntry e;
    e.frame = static_cast<int>(v[0]);
    e.deliver_t_s = v[1];
    PlatformObservation& o = e.result.obs;
    o.t_s = v[2];
    o.detected = v[3] != 0;
    o.keyframe = v[4] != 0;
    o.rings_identified = static_cast<int>(v[5]);
    o.reproj_err_px = v[6];
    e.result.h_plane_m = v[7];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) o.X_CP.linear()(r, c) = v[8 + 3 * r + c];
    }
    for (int i = 0; i < 3; ++i) o.X_CP.translation()[i] = v[17 + i];
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) o.cov(r, c) = v[20 + 6 * r + c];
    }
    log.push_back(e);
  }
  return log;
}

}  // namespace lander::sim
