#include "lander/sim/plant/world.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <opencv2/imgproc.hpp>

#include "lander/sim/plant/mujoco_errors.h"

namespace lander::sim {

Eigen::Matrix3d R_mujocoCam_opencvCam() { return Eigen::Vector3d(1, -1, -1).asDiagonal(); }

namespace {

int require_id(const mjModel* m, mjtObj type, const char* name, const std::string& file) {
  const int id = mj_name2id(m, type, name);
  if (id < 0) throw ConfigError(file + ": model has no " + std::string(mju_type2Str(type)) +
                                " named '" + name + "'");
  return id;
}

Eigen::Isometry3d pose_from(const mjtNum* pos, const mjtNum* mat) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(pos[0], pos[1], pos[2]);
  X.linear() = Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>>(mat);
  return X;
}

// Places the route's paint and the distractor patches on the placeholder geoms of the model
// (models/world_route.xml: route_box_*, route_disc_*, paint_box_*), moved from the hidden group 4
// to group 0 like the lane markings (rays of the rangefinder and the ground effect see the
// paint's 6 mm as they would). Thin boxes lie on the ground; the route's top is 6 mm above it, above the lane
// markings' 5 mm so the two never fight for depth where they cross; distractors 7 mm.
void paint_route(mjModel* m, const RouteParams& rp, const RouteGeometry& route, const std::string& file) {
  auto place = [&](const std::string& prefix, int& next, const Eigen::Vector2d& c, double yaw,
                   const Eigen::Vector3d& half, const Eigen::Vector3d& rgb) {
    const std::string name = prefix + std::to_string(next);
    const int g = mj_name2id(m, mjOBJ_GEOM, name.c_str());
    if (g < 0) {
      throw ConfigError(file + ": the route needs more paint pieces than the model has placeholders ('" +
                        name + "' is missing; models/world_route.xml has them)");
    }
    ++next;
    m->geom_pos[3 * g] = c.x();
    m->geom_pos[3 * g + 1] = c.y();
    m->geom_pos[3 * g + 2] = half.z();
    m->geom_quat[4 * g] = std::cos(0.5 * yaw);
    m->geom_quat[4 * g + 1] = 0;
    m->geom_quat[4 * g + 2] = 0;
    m->geom_quat[4 * g + 3] = std::sin(0.5 * yaw);
    for (int i = 0; i < 3; ++i) {
      m->geom_size[3 * g + i] = half[i];
      m->geom_rgba[4 * g + i] = static_cast<float>(rgb[i]);
    }
    m->geom_rgba[4 * g + 3] = 1.0f;
    m->geom_rbound[g] = m->geom_type[g] == mjGEOM_CYLINDER ? std::hypot(half.x(), half.z()) : half.norm();
    m->geom_group[g] = 0;
  };
  int boxes = 0, discs = 0, patches = 0;
  const double w2 = 0.5 * rp.width_m, top = 0.003;
  for (const RouteGeometry::Rect& r : route.paint_rects()) {
    place("route_box_", boxes, r.centre_m, r.heading_rad, {0.5 * r.length_m, w2, top}, rp.rgb);
  }
  for (const Eigen::Vector2d& c : route.paint_discs()) {
    // A cylinder's size is (radius, half-height, unused).
    place("route_disc_", discs, c, 0.0, {w2, top, top}, rp.rgb);
  }
  for (const PaintPatch& p : rp.paint) {
    place("paint_box_", patches, p.centre_m, p.yaw_rad, {0.5 * p.size_m.x(), 0.5 * p.size_m.y(), 0.0035}, p.rgb);
  }
}

}  // namespace

namespace {

// The MJCF to load: a custom model as given; the default world in the variant the scenario
// needs. A painted route needs the paint's placeholder geoms (models/world_route.xml: world.xml
// plus the placeholders, which would cost every other run ~0.1 ms a physics step), a moving
// deck the deck's joints (world_deck.xml), both world_route_deck.xml. A custom model must hold
// them itself.
std::string model_variant(const WorldParams& params, bool painted, bool moving_deck) {
  const std::string default_world = models_dir() + "/world.xml";
  std::error_code ec;
  const bool is_default = params.model_path == default_world ||
                          std::filesystem::equivalent(params.model_path, default_world, ec);
  if (!is_default || (!painted && !moving_deck)) return params.model_path;
  if (painted && moving_deck) return models_dir() + "/world_route_deck.xml";
  return models_dir() + (painted ? "/world_route.xml" : "/world_deck.xml");
}

}  // namespace

World::World(const WorldParams& params, const CameraModel& camera, bool moving_deck) : camera_(camera) {
  params.validate();
  camera.validate();
  install_mujoco_handlers();
  const bool painted = params.route.present() || !params.route.paint.empty();
  const std::string model_path = model_variant(params, painted, moving_deck);
  if (!std::ifstream(model_path)) {
    throw ConfigError(model_path + ": cannot open model file");
  }
  target_ = TargetGeometry::load(params.target_path);
  route_ = RouteGeometry(params.route);
  char err[1024] = "";
  try {
    m_ = mj_loadXML(model_path.c_str(), nullptr, err, sizeof(err));
  } catch (const MujocoError& e) {
    throw ConfigError(model_path + ": " + e.what());
  }
  if (!m_) throw ConfigError(model_path + ": MuJoCo cannot load the model: " + err);
  // MuJoCo 2.2 keeps the parsed XML model (with the compiler's copy of every texture, 62 MB
  // for the default world) until the next load, for mj_saveLastXML, which nothing here calls.
  mj_freeLastXML();
  d_ = mj_makeData(m_);
  m_->opt.timestep = params.physics_dt_s;
  const std::string& f = model_path;
  vehicle_body_ = require_id(m_, mjOBJ_BODY, "hexarotor", f);
  cart_body_ = require_id(m_, mjOBJ_BODY, "cart", f);
  camera_id_ = require_id(m_, mjOBJ_CAMERA, "downcam", f);
  platform_site_ = require_id(m_, mjOBJ_SITE, "platform_P", f);
  for (int k = 0; k < 6; ++k) {
    rotor_sites_[k] = require_id(m_, mjOBJ_SITE, ("rotor" + std::to_string(k)).c_str(), f);
  }
  const int free = require_id(m_, mjOBJ_JOINT, "hexarotor_free", f);
  vehicle_qpos_ = m_->jnt_qposadr[free];
  vehicle_qvel_ = m_->jnt_dofadr[free];
  const char* cart_joints[3] = {"cart_x", "cart_y", "cart_yaw"};
  for (int i = 0; i < 3; ++i) {
    const int j = require_id(m_, mjOBJ_JOINT, cart_joints[i], f);
    cart_qpos_[i] = m_->jnt_qposadr[j];
    cart_dof_[i] = m_->jnt_dofadr[j];
  }
  if (moving_deck) find_deck_joints(f);
  // The MuJoCo camera renders a centred pinhole; its fovy fixes fy = (H / 2) / tan(fovy / 2).
  // Off-centre principal points and distortion are applied after rendering (camera.cpp).
  const cv::Size render = pinhole_render_size(camera_);
  m_->cam_fovy[camera_id_] = 2.0 * std::atan(0.5 * render.height / camera_.fy_px) * 180.0 / M_PI;
  reserve_offscreen(render.width, render.height);
  if (m_->vis.global.offwidth > kMaxRenderSidePx || m_->vis.global.offheight > kMaxRenderSidePx) {
    throw ConfigError(model_path + ": <visual><global offwidth/offheight> " +
                      std::to_string(m_->vis.global.offwidth) + "x" +
                      std::to_string(m_->vis.global.offheight) + " exceeds the offscreen limit " +
                      std::to_string(kMaxRenderSidePx) + " px");
  }

  ground_seed_ = params.ground_seed;
  generate_texture("target_tex");
  if (mj_name2id(m_, mjOBJ_TEXTURE, "ground_tex") >= 0) generate_texture("ground_tex");
  if (painted) paint_route(m_, params.route, route_, model_path);
  mj_forward(m_, d_);
}

void World::reserve_offscreen(int width_px, int height_px) {
  if (width_px > kMaxRenderSidePx || height_px > kMaxRenderSidePx) {
    throw ConfigError("render size " + std::to_string(width_px) + "x" +
                      std::to_string(height_px) + " exceeds the offscreen limit " +
                      std::to_string(kMaxRenderSidePx) + " px");
  }
  m_->vis.global.offwidth = std::max(m_->vis.global.offwidth, width_px);
  m_->vis.global.offheight = std::max(m_->vis.global.offheight, height_px);
}

World::~World() {
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

void World::set_texture(const std::string& name, const cv::Mat& bgr) {
  // The model is whole again before one texture changes (a context made from it next
  // uploads every texture); this one is no longer World's own, so never released.
  // (This one's pages are all written below.)
  released_.erase(name);
  restore_texture_pixels();
  generated_.erase(name);
  write_texture(name, bgr);
}

void World::generate_texture(const std::string& name) {
  if (name == "target_tex") {
    write_texture(name, render_target_texture(target_));
  } else {
    const int id = mj_name2id(m_, mjOBJ_TEXTURE, name.c_str());
    write_texture(name, make_ground_texture(m_->tex_width[id], ground_seed_));
  }
  generated_.insert(name);
}

namespace {

// The whole pages inside texture `id`'s pixels (MuJoCo's model is one allocation, so only
// these can go back to the system); empty when the texture is smaller than two pages.
std::pair<unsigned char*, std::size_t> texture_pages(const mjModel* m, int id) {
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<std::uintptr_t>(m->tex_rgb + m->tex_adr[id]);
  const auto end = begin + static_cast<std::uintptr_t>(m->tex_width[id]) * m->tex_height[id] * 3;
  const std::uintptr_t first = (begin + page - 1) / page * page, last = end / page * page;
  if (last <= first) return {nullptr, 0};
  return {reinterpret_cast<unsigned char*>(first), last - first};
}

}  // namespace

std::size_t World::release_texture_pixels() {
  std::size_t released = 0;
  for (const std::string& name : generated_) {
    if (released_.count(name)) continue;
    const auto [pages, bytes] = texture_pages(m_, mj_name2id(m_, mjOBJ_TEXTURE, name.c_str()));
    // Private anonymous memory (MuJoCo's malloc'd model): the pages are dropped and read back
    // as zeros until written again.
    if (bytes > 0 && madvise(pages, bytes, MADV_DONTNEED) != 0) continue;
    released_.insert(name);
    released += bytes;
  }
  return released;
}

void World::restore_texture_pixels() {
  const std::set<std::string> released = std::move(released_);
  released_.clear();
  for (const std::string& name : released) generate_texture(name);
}

std::size_t World::texture_pixel_bytes() const {
  std::size_t held = static_cast<std::size_t>(m_->ntexdata);
  for (const std::string& name : released_) {
    held -= texture_pages(m_, mj_name2id(m_, mjOBJ_TEXTURE, name.c_str())).second;
  }
  return held;
}

void World::write_texture(const std::string& name, const cv::Mat& bgr) {
  const int id = mj_name2id(m_, mjOBJ_TEXTURE, name.c_str());
  if (id < 0) throw ConfigError("model has no texture named '" + name + "'");
  const int w = m_->tex_width[id], h = m_->tex_height[id];
  if (bgr.cols != w || bgr.rows != h || bgr.type() != CV_8UC3) {
    throw ConfigError("texture '" + name + "' is " + std::to_string(w) + "x" + std::to_string(h) +
                      " in the model, image is " + std::to_string(bgr.cols) + "x" +
                      std::to_string(bgr.rows));
  }
  // MuJoCo stores RGB rows; row 0 of the image becomes texture row 0.
  unsigned char* dst = m_->tex_rgb + m_->tex_adr[id];
  for (int r = 0; r < h; ++r) {
    cv::Mat row(1, w, CV_8UC3, dst + static_cast<std::size_t>(r) * w * 3);
    cv::cvtColor(bgr.row(r), row, cv::COLOR_BGR2RGB);
  }
}

Eigen::Isometry3d World::X_WB() const {
  return pose_from(d_->xpos + 3 * vehicle_body_, d_->xmat + 9 * vehicle_body_);
}

Eigen::Isometry3d World::X_WC() const {
  Eigen::Isometry3d X = pose_from(d_->cam_xpos + 3 * camera_id_, d_->cam_xmat + 9 * camera_id_);
  X.linear() = X.linear() * R_mujocoCam_opencvCam();
  return X;
}

Eigen::Isometry3d World::X_WP() const {
  return pose_from(d_->site_xpos + 3 * platform_site_, d_->site_xmat + 9 * platform_site_);
}

Eigen::Vector3d World::v_WB() const {
  return Eigen::Vector3d(d_->qvel[vehicle_qvel_], d_->qvel[vehicle_qvel_ + 1],
                         d_->qvel[vehicle_qvel_ + 2]);
}

Eigen::Vector3d World::omega_B() const {
  // MuJoCo's free joint angular velocity is expressed in the body frame.
  return Eigen::Vector3d(d_->qvel[vehicle_qvel_ + 3], d_->qvel[vehicle_qvel_ + 4],
                         d_->qvel[vehicle_qvel_ + 5]);
}

void World::set_vehicle_state(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v_W,
                              const Eigen::Vector3d& omega_B) {
  const Eigen::Quaterniond q(X_WB.linear());
  mjtNum* qp = d_->qpos + vehicle_qpos_;
  qp[0] = X_WB.translation().x();
  qp[1] = X_WB.translation().y();
  qp[2] = X_WB.translation().z();
  qp[3] = q.w();
  qp[4] = q.x();
  qp[5] = q.y();
  qp[6] = q.z();
  mjtNum* qv = d_->qvel + vehicle_qvel_;
  for (int i = 0; i < 3; ++i) {
    qv[i] = v_W[i];
    qv[3 + i] = omega_B[i];
  }
}

namespace {

// Three entries of MuJoCo's state vector `v` at the addresses `adr` (the cart's or the deck's
// three joints), and the other way.
Eigen::Vector3d gather3(const mjtNum* v, const int (&adr)[3]) { return {v[adr[0]], v[adr[1]], v[adr[2]]}; }

void scatter3(const Eigen::Vector3d& x, const int (&adr)[3], mjtNum* v) {
  for (int i = 0; i < 3; ++i) v[adr[i]] = x[i];
}

}  // namespace

void World::set_cart_state(const Eigen::Vector3d& q, const Eigen::Vector3d& qd) {
  scatter3(q, cart_qpos_, d_->qpos);
  scatter3(qd, cart_dof_, d_->qvel);
}

Eigen::Vector3d World::cart_q() const { return gather3(d_->qpos, cart_qpos_); }

Eigen::Vector3d World::cart_qd() const { return gather3(d_->qvel, cart_dof_); }

void World::find_deck_joints(const std::string& file) {
  deck_body_ = require_id(m_, mjOBJ_BODY, "deck", file);
  const char* joints[3] = {"deck_heave", "deck_roll", "deck_pitch"};
  for (int i = 0; i < 3; ++i) {
    const int j = require_id(m_, mjOBJ_JOINT, joints[i], file);
    deck_qpos_[i] = m_->jnt_qposadr[j];
    deck_dof_[i] = m_->jnt_dofadr[j];
  }
  if (m_->nu < 6) {
    throw ConfigError(file + ": a moving deck needs six motors: the cart's three, then deck_heave, deck_roll, deck_pitch");
  }
}

void World::set_deck_state(const Eigen::Vector3d& q, const Eigen::Vector3d& qd) {
  scatter3(q, deck_qpos_, d_->qpos);
  scatter3(qd, deck_dof_, d_->qvel);
}

Eigen::Vector3d World::deck_q() const { return gather3(d_->qpos, deck_qpos_); }

Eigen::Vector3d World::deck_qd() const { return gather3(d_->qvel, deck_dof_); }

Eigen::Vector3d World::cart_point_velocity_W(const Eigen::Vector3d& p_W) const {
  if (has_deck()) {
    // The deck's rigid-body velocity (all six components: the cart's path, heave, roll,
    // pitch) at p_W: MuJoCo's velocity of the deck body at its centre of mass (xipos: where
    // mj_objectVelocity puts a body's velocity), world axes.
    mjtNum v[6];
    mj_objectVelocity(m_, d_, mjOBJ_BODY, deck_body_, v, 0);
    const Eigen::Vector3d w(v[0], v[1], v[2]), v_o(v[3], v[4], v[5]);
    const Eigen::Vector3d o(d_->xipos[3 * deck_body_], d_->xipos[3 * deck_body_ + 1], d_->xipos[3 * deck_body_ + 2]);
    return v_o + w.cross(p_W - o);
  }
  const Eigen::Vector3d q = cart_q(), qd = cart_qd();
  const Eigen::Vector3d r(p_W.x() - q.x(), p_W.y() - q.y(), 0.0);
  return Eigen::Vector3d(qd.x(), qd.y(), 0.0) + Eigen::Vector3d(0.0, 0.0, qd.z()).cross(r);
}

void World::forward() { mj_forward(m_, d_); }

bool World::state_finite() const {
  for (int i = 0; i < m_->nq; ++i) {
    if (!std::isfinite(d_->qpos[i])) return false;
  }
  for (int i = 0; i < m_->nv; ++i) {
    if (!std::isfinite(d_->qvel[i])) return false;
  }
  return true;
}

double World::ray_distance(const Eigen::Vector3d& p_W, const Eigen::Vector3d& dir_W) const {
  mjtNum pnt[3] = {p_W.x(), p_W.y(), p_W.z()};
  Eigen::Vector3d u = dir_W.normalized();
  mjtNum vec[3] = {u.x(), u.y(), u.z()};
  int geomid = -1;
  // Only geoms that collide (group 0..2, include static), excluding the vehicle's body.
  const mjtByte groups[mjNGROUP] = {1, 1, 1, 0, 0, 0};
  const mjtNum dist = mj_ray(m_, d_, pnt, vec, groups, 1, vehicle_body_, &geomid);
  if (dist < 0 || dist > 100.0) return -1.0;
  return dist;
}

cv::Mat make_ground_texture(int size_px, std::uint64_t seed) {
  // Sum of value-noise octaves (asphalt grain + larger stains), in grey with a slight tint.
  cv::Mat acc(size_px, size_px, CV_32F, cv::Scalar(0));
  cv::RNG rng(seed);
  float amplitude = 0.5f, total = 0.f;
  for (int cells = 8; cells <= size_px; cells *= 4) {
    cv::Mat small(cells, cells, CV_32F);
    rng.fill(small, cv::RNG::UNIFORM, 0.0, 1.0);
    // Wrap-around so the tile repeats seamlessly: pad, resize, crop.
    cv::Mat padded;
    cv::copyMakeBorder(small, padded, 1, 1, 1, 1, cv::BORDER_WRAP);
    cv::Mat big;
    const int scale = size_px / cells;
    cv::resize(padded, big, cv::Size((cells + 2) * scale, (cells + 2) * scale), 0, 0,
               cv::INTER_CUBIC);
    acc += amplitude * big(cv::Rect(scale, scale, size_px, size_px));
    total += amplitude;
    amplitude *= 0.6f;
  }
  acc /= total;
  cv::Mat grey;
  acc.convertTo(grey, CV_8U, 110.0, 40.0);  // mid-dark grey, contrast about 0.3
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{grey, grey + 4, grey + 8}, bgr);
  return bgr;
}

}  // namespace lander::sim
