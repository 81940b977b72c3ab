#include "lander/sim/loop/vision_log.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "lander/core/params_io.h"
#include "lander/sim/util/output_files.h"

namespace lander::sim {

namespace {
// Version 1 (ring results only) is still read; version 2 adds the path stage's result: a flag,
// then when set t_s, fx, fy, cx, cy, the number of points and their (u, v).
constexpr const char* kHeaderV1 =
    "frame,deliver_t_s,t_s,detected,keyframe,rings_identified,reproj_err_px,h_plane_m,"
    "R00,R01,R02,R10,R11,R12,R20,R21,R22,tx,ty,tz,cov[36]";
const std::string kHeader = std::string(kHeaderV1) + ",path[has,t_s,fx,fy,cx,cy,n,(u,v)*n]";
constexpr int kFields = 8 + 9 + 3 + 36;
constexpr int kMaxPathPoints = 10000;
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
    if (const auto& p = e.result.path) {
      row += fmt::format(",1,{:a},{:a},{:a},{:a},{:a},{}", p->t_s, p->fx, p->fy, p->cx, p->cy, p->points_px.size());
      for (const Eigen::Vector2d& q : p->points_px) row += fmt::format(",{:a},{:a}", q.x(), q.y());
    } else {
      row += ",0";
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
  const bool v2 = line == kHeader;
  if (!v2 && line != kHeaderV1) throw ConfigError(path + ":1: not a vision log (unexpected header)");
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
    // Version 2: the path part's length follows from its flag and point count.
    std::size_t expected = kFields;
    if (v2) {
      expected += 1;
      if (v.size() > kFields && v[kFields] != 0) {
        const double n = v.size() > kFields + 6 ? v[kFields + 6] : -1;
        if (!(n >= 0 && n <= kMaxPathPoints) || n != std::floor(n)) {
          throw ConfigError(fmt::format("{}:{}: bad path point count", path, line_no));
        }
        expected += 6 + 2 * static_cast<std::size_t>(n);
      }
    }
    if (v.size() != expected) {
      throw ConfigError(fmt::format("{}:{}: {} fields, expected {}", path, line_no, v.size(), expected));
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
    if (v2 && v[kFields] != 0) {
      PathObservation p;
      p.t_s = v[kFields + 1];
      p.fx = v[kFields + 2];
      p.fy = v[kFields + 3];
      p.cx = v[kFields + 4];
      p.cy = v[kFields + 5];
      const int n = static_cast<int>(v[kFields + 6]);
      for (int i = 0; i < n; ++i) p.points_px.emplace_back(v[kFields + 7 + 2 * i], v[kFields + 8 + 2 * i]);
      p.valid = n > 0;
      e.result.path = std::move(p);
    }
    log.push_back(e);
  }
  return log;
}

}  // namespace lander::sim
