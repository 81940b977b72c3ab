// The recorded-vision log (sim/loop/vision_log.h) that drives the change indication: every bit
// of a delivered vision result, ring pose and path points, survives a write and a read; the
// older ring-only format still reads; a malformed row names the file and line.
#include <gtest/gtest.h>

#include <stdlib.h>

#include <cmath>
#include <fstream>

#include "lander/sim/loop/vision_log.h"

namespace lander::sim {
namespace {

std::string make_temp_dir(const std::string& prefix) {
  std::string name = "/tmp/" + prefix + "_XXXXXX";
  if (!mkdtemp(name.data())) throw std::runtime_error("mkdtemp failed");
  return name;
}

VisionLogEntry entry(int frame, bool with_path) {
  VisionLogEntry e;
  e.frame = frame;
  e.deliver_t_s = 0.1 * frame + 1.0 / 3.0;
  e.result.obs.t_s = 0.1 * frame;
  e.result.obs.detected = true;
  e.result.obs.keyframe = frame % 2 == 0;
  e.result.obs.rings_identified = 7;
  e.result.obs.reproj_err_px = 0.0123456789;
  e.result.obs.X_CP.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  e.result.obs.X_CP.translation() = Eigen::Vector3d(0.1, -0.2, M_PI);
  e.result.obs.cov = Eigen::Matrix<double, 6, 6>::Identity() * 1e-7;
  e.result.h_plane_m = std::nan("");
  if (with_path) {
    PathObservation p;
    p.t_s = 0.1 * frame;
    p.fx = 1000.5;
    p.fy = 1000.25;
    p.cx = 639.5;
    p.cy = 359.5;
    p.points_px = {Eigen::Vector2d(1.0 / 7.0, 2.5), Eigen::Vector2d(1279.75, 0.0)};
    p.valid = true;
    e.result.path = p;
  }
  return e;
}

TEST(VisionLog, RingPosesAndPathPointsSurviveBitForBit) {
  const std::string dir = make_temp_dir("vision_log");
  const std::vector<VisionLogEntry> in = {entry(0, false), entry(1, true), entry(2, false)};
  write_vision_log(dir + "/v.csv", in);
  const std::vector<VisionLogEntry> out = read_vision_log(dir + "/v.csv");
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(out[i].frame, in[i].frame);
    EXPECT_EQ(out[i].deliver_t_s, in[i].deliver_t_s);
    EXPECT_EQ(out[i].result.obs.keyframe, in[i].result.obs.keyframe);
    EXPECT_TRUE(out[i].result.obs.X_CP.matrix() == in[i].result.obs.X_CP.matrix());
    EXPECT_TRUE(out[i].result.obs.cov == in[i].result.obs.cov);
    EXPECT_TRUE(std::isnan(out[i].result.h_plane_m));
    ASSERT_EQ(out[i].result.path.has_value(), in[i].result.path.has_value()) << i;
    if (in[i].result.path) {
      const PathObservation &a = *in[i].result.path, &b = *out[i].result.path;
      EXPECT_EQ(b.t_s, a.t_s);
      EXPECT_EQ(b.fx, a.fx);
      EXPECT_EQ(b.cy, a.cy);
      ASSERT_EQ(b.points_px.size(), a.points_px.size());
      for (std::size_t k = 0; k < a.points_px.size(); ++k) EXPECT_TRUE(b.points_px[k] == a.points_px[k]);
    }
  }
}

TEST(VisionLog, RingOnlyLogsOfTheFirstFormatStillRead) {
  const std::string dir = make_temp_dir("vision_log_v1");
  write_vision_log(dir + "/v2.csv", {entry(4, false)});
  // The first format: the same header and rows without the path part.
  std::ifstream f(dir + "/v2.csv");
  std::string header, row;
  std::getline(f, header);
  std::getline(f, row);
  header = header.substr(0, header.rfind(",path["));
  row = row.substr(0, row.rfind(",0"));
  std::ofstream(dir + "/v1.csv") << header << "\n" << row << "\n";
  const std::vector<VisionLogEntry> out = read_vision_log(dir + "/v1.csv");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, 4);
  EXPECT_FALSE(out[0].result.path.has_value());
}

TEST(VisionLog, AMalformedPathPartNamesTheFileAndLine) {
  const std::string dir = make_temp_dir("vision_log_bad");
  write_vision_log(dir + "/v.csv", {entry(0, false), entry(1, true)});
  std::ifstream f(dir + "/v.csv");
  std::string header, row0, row1;
  std::getline(f, header);
  std::getline(f, row0);
  std::getline(f, row1);
  row1 = row1.substr(0, row1.rfind(','));  // one coordinate short
  std::ofstream(dir + "/v.csv") << header << "\n" << row0 << "\n" << row1 << "\n";
  try {
    read_vision_log(dir + "/v.csv");
    FAIL() << "a short path part was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("v.csv:3:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lander::sim
