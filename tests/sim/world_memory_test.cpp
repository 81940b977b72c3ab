// What the World holds besides the physics (issue 53, "the cost of a landing"): MuJoCo's parsed
// XML model is not kept, and the model's copy of the textures World generated goes back to the
// system once a rendering context holds them, and comes back byte for byte. The bounds are
// computed from the model's texture sizes and the page size, not measured as the process's RSS.
#include <gtest/gtest.h>

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <vector>

#include "lander/sim/plant/world.h"

namespace lander::sim {
namespace {

std::size_t texture_bytes(const mjModel* m, const char* name) {
  const int id = mj_name2id(m, mjOBJ_TEXTURE, name);
  EXPECT_GE(id, 0) << name;
  return static_cast<std::size_t>(m->tex_width[id]) * m->tex_height[id] * 3;
}

// FNV-1a over the model's pixels of texture `name`.
std::uint64_t texture_hash(const mjModel* m, const char* name) {
  const int id = mj_name2id(m, mjOBJ_TEXTURE, name);
  const unsigned char* p = m->tex_rgb + m->tex_adr[id];
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < texture_bytes(m, name); ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

// Pages of texture `name` the kernel reports resident (mincore), of those wholly inside it.
std::size_t resident_pages(const mjModel* m, const char* name) {
  const int id = mj_name2id(m, mjOBJ_TEXTURE, name);
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<std::uintptr_t>(m->tex_rgb + m->tex_adr[id]);
  const std::uintptr_t first = (begin + page - 1) / page * page;
  const std::uintptr_t last = (begin + texture_bytes(m, name)) / page * page;
  std::vector<unsigned char> vec((last - first) / page);
  EXPECT_EQ(mincore(reinterpret_cast<void*>(first), last - first, vec.data()), 0);
  std::size_t n = 0;
  for (unsigned char v : vec) n += v & 1;
  return n;
}

TEST(WorldMemory, ParsedXmlModelIsNotKept) {
  World world(WorldParams{}, CameraModel{});
  // MuJoCo 2.2 keeps the last parsed XML (a second copy of every texture) for mj_saveLastXML.
  char err[200] = "";
  EXPECT_EQ(mj_saveLastXML("/dev/null", world.model(), err, sizeof(err)), 0);
  EXPECT_STREQ(err, "No XML model loaded");
}

TEST(WorldMemory, GeneratedTexturesAreReleasedAndRestoredExactly) {
  World world(WorldParams{}, CameraModel{});
  const mjModel* m = world.model();
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  const std::size_t generated = texture_bytes(m, "target_tex") + texture_bytes(m, "ground_tex");
  ASSERT_EQ(world.texture_pixel_bytes(), static_cast<std::size_t>(m->ntexdata));
  const std::uint64_t target = texture_hash(m, "target_tex"), ground = texture_hash(m, "ground_tex");

  const std::size_t released = world.release_texture_pixels();
  // Everything but at most one partial page at either end of each generated texture.
  EXPECT_GE(released, generated - 4 * page);
  EXPECT_LE(world.texture_pixel_bytes(), m->ntexdata - generated + 4 * page);
  EXPECT_EQ(resident_pages(m, "target_tex"), 0u);
  EXPECT_EQ(resident_pages(m, "ground_tex"), 0u);
  EXPECT_EQ(world.release_texture_pixels(), 0u);  // nothing left to release

  world.restore_texture_pixels();
  EXPECT_EQ(world.texture_pixel_bytes(), static_cast<std::size_t>(m->ntexdata));
  EXPECT_EQ(texture_hash(m, "target_tex"), target);
  EXPECT_EQ(texture_hash(m, "ground_tex"), ground);
}

TEST(WorldMemory, SetTextureRestoresTheOthersAndKeepsItsOwn) {
  World world(WorldParams{}, CameraModel{});
  const mjModel* m = world.model();
  const std::uint64_t ground = texture_hash(m, "ground_tex");
  world.release_texture_pixels();
  const TargetGeometry& g = world.target();
  world.set_texture("target_tex", cv::Mat(g.texture_px, g.texture_px, CV_8UC3,
                                          cv::Scalar(255, 255, 255)));
  EXPECT_EQ(world.texture_pixel_bytes(), static_cast<std::size_t>(m->ntexdata));
  EXPECT_EQ(texture_hash(m, "ground_tex"), ground);
  // A texture given to set_texture is the caller's: World cannot regenerate it, so keeps it.
  const std::uint64_t white = texture_hash(m, "target_tex");
  world.release_texture_pixels();
  EXPECT_EQ(texture_hash(m, "target_tex"), white);
  EXPECT_GT(resident_pages(m, "target_tex"), 0u);
}

}  // namespace
}  // namespace lander::sim
