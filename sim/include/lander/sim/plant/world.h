// The MuJoCo world: ground with distractors, the cart with the landing platform, the
// hexarotor. Owns mjModel/mjData; fills the target texture from models/target.yaml (single
// source of truth) and the ground texture procedurally at load time; answers truth queries
// (poses of B, C and P in W) for the logger, the metrics and the tests only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <set>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <mujoco/mujoco.h>

#include "lander/core/params_io.h"
#include "lander/estimator/target.h"
#include "lander/core/types.h"
#include "lander/sim/plant/route.h"
#include "lander/sim/sensors/camera.h"

namespace lander::sim {

// The light the scene is lit by (the sun, a directional light, and the renderer's headlight,
// an ambient term). The defaults are those of models/world.xml.
struct LightParams {
  Eigen::Vector3d sun_dir_W{-0.3, -0.2, -1.0};  ///< direction the sunlight travels, in W
  double sun_intensity{0.55};   ///< diffuse intensity of the sun (0..1 per colour channel)
  double ambient{0.35};         ///< headlight ambient intensity (0..1)
  double headlight{0.35};       ///< headlight diffuse intensity (0..1)
  // Shadows (the sun's, of the vehicle and the cart on the rings) are render.shadows.
  void validate() const {
    check_fields(*this);
    require(sun_dir_W.norm() > 1e-6 && sun_dir_W.z() < 0, "sun_dir",
            "must point downwards (z < 0)");
  }
};

template <class V>
void visit_fields(V& v, LightParams& p) {
  v("sun_dir", p.sun_dir_W, range::any, "", "direction the sunlight travels");
  v("sun_intensity", p.sun_intensity, range::closed(0, 1), "",
    "diffuse intensity of the sun (0..1 per colour channel)");
  v("ambient", p.ambient, range::closed(0, 1), "", "headlight ambient intensity");
  v("headlight", p.headlight, range::closed(0, 1), "", "headlight diffuse intensity");
}

struct WorldParams {
  std::string model_path{models_dir() + "/world.xml"};    ///< MJCF world
  std::string target_path{models_dir() + "/target.yaml"};  ///< target YAML
  double physics_dt_s{0.001};      ///< physics step (s); 1 kHz default
  std::uint64_t ground_seed{7};    ///< seed of the procedural ground texture
  LightParams light;
  RouteParams route;               ///< a painted route on the ground (none by default)
  void validate() const {
    check_fields(*this);
    validate_nested("light", light);
    validate_nested("route", route);
    require(!model_path.empty(), "model", "must name an MJCF file");
    require(!target_path.empty(), "target", "must name a target YAML");
  }
};

template <class V>
void visit_fields(V& v, WorldParams& p) {
  v("model", p.model_path, range::any, "", "MJCF world");
  v("target", p.target_path, range::any, "", "target YAML");
  v("dt_ms", p.physics_dt_s, range::open_closed(0, 5), "ms", "physics step", 1e-3);
  v("ground_seed", p.ground_seed, range::any, "", "seed of the procedural ground texture");
  v.nested("light", p.light);
  v.nested("route", p.route);
}

// Converts between MuJoCo's camera frame (looks along -z, y up) and the OpenCV frame C
// (x right, y down, z along the optical axis): R_mj_C = diag(1, -1, -1). Written once here.
Eigen::Matrix3d R_mujocoCam_opencvCam();

class World {
 public:
  // Loads the MJCF, applies the camera model (fovy from fy) and fills the textures. Throws
  // ConfigError for a missing/unreadable model or target, MujocoError for a model MuJoCo
  // rejects, with the file named. With `moving_deck` (a scenario's cart.deck_motion) the
  // default world is models/world_deck.xml (the platform on a deck with heave, roll and pitch
  // joints); a custom model must then have the body "deck" and the joints deck_heave,
  // deck_roll and deck_pitch with their motors after the cart's.
  World(const WorldParams& params, const CameraModel& camera, bool moving_deck = false);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  const mjModel* model() const { return m_; }
  mjModel* model() { return m_; }
  mjData* data() { return d_; }
  const mjData* data() const { return d_; }
  const TargetGeometry& target() const { return target_; }
  const RouteGeometry& route() const { return route_; }  ///< the painted route (truth)
  const CameraModel& camera() const { return camera_; }
  double time() const { return d_->time; }

  // MuJoCo ids used by the simulator.
  int vehicle_body() const { return vehicle_body_; }
  int camera_id() const { return camera_id_; }
  int platform_site() const { return platform_site_; }
  int rotor_site(int k) const { return rotor_sites_[k]; }
  int cart_body() const { return cart_body_; }
  int vehicle_qpos_adr() const { return vehicle_qpos_; }  ///< first qpos of the free joint
  int vehicle_dof_adr() const { return vehicle_qvel_; }   ///< first dof of the free joint

  // Truth (never handed to the estimator or controller).
  Eigen::Isometry3d X_WB() const;  ///< vehicle body pose
  Eigen::Isometry3d X_WC() const;  ///< camera pose, OpenCV convention
  Eigen::Isometry3d X_WP() const;  ///< platform frame P
  Eigen::Vector3d v_WB() const;    ///< vehicle linear velocity in W (m/s)
  Eigen::Vector3d omega_B() const; ///< vehicle angular velocity in B (rad/s)

  // Kinematic placement (scripted runs, tests): sets the free joint state only; forward()
  // then recomputes the positions that X_WC(), X_WP() and the renders read. v and omega only
  // matter to sensors that read velocities.
  void set_vehicle_state(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v_W,
                         const Eigen::Vector3d& omega_B);
  // Cart joint state: position (x, y) in W (m), yaw (rad), and rates.
  void set_cart_state(const Eigen::Vector3d& q_xy_yaw, const Eigen::Vector3d& qd);
  Eigen::Vector3d cart_q() const;   ///< (x, y, yaw)
  Eigen::Vector3d cart_qd() const;  ///< rates
  // Velocity in W of a point p_W carried by the cart (its x, y and yaw rates) (m/s).
  Eigen::Vector3d cart_point_velocity_W(const Eigen::Vector3d& p_W) const;
  int cart_dof(int i) const { return cart_dof_[i]; }
  // The deck's joints (models/cart_deck.xml): (heave m, roll rad, pitch rad), when loaded
  // with moving_deck.
  bool has_deck() const { return deck_body_ >= 0; }
  void set_deck_state(const Eigen::Vector3d& q, const Eigen::Vector3d& qd);
  Eigen::Vector3d deck_q() const;
  Eigen::Vector3d deck_qd() const;
  int deck_dof(int i) const { return deck_dof_[i]; }
  void forward();
  // True when every position and velocity of the physics state is finite.
  bool state_finite() const;

  // Grows MuJoCo's offscreen buffer to hold a width x height render (call before the
  // renderer is created). Throws ConfigError beyond kMaxRenderSidePx (camera.h).
  void reserve_offscreen(int width_px, int height_px);

  // Fills a model texture with a BGR image (same size as the placeholder). Call before the
  // renderer is created (textures are uploaded when the GL context is made), or re-upload.
  // Restores released pixels first (restore_texture_pixels()).
  void set_texture(const std::string& name, const cv::Mat& bgr);

  // The model's pixels of the textures World generated itself (target_tex from the target
  // YAML, ground_tex from ground_seed; not those given to set_texture) go back to the system
  // once a rendering context holds its own copy: MuJoCo reads mjModel::tex_rgb only when a
  // context is made or a texture uploaded. Until restore_texture_pixels() (or set_texture())
  // those pixels read as zeros: no rendering context may be made from the model meanwhile.
  // Returns the bytes released (whole pages only).
  std::size_t release_texture_pixels();
  // Regenerates the released pixels (the same bytes as at load).
  void restore_texture_pixels();
  // Bytes of texture pixels the model holds: mjModel::ntexdata less the released pages.
  std::size_t texture_pixel_bytes() const;

  // Distance (m) from point p_W along direction dir_W to the first geom (ground, platform,
  // anything with a collision group), excluding the vehicle itself; -1 if none within 100 m.
  double ray_distance(const Eigen::Vector3d& p_W, const Eigen::Vector3d& dir_W) const;

 private:
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  TargetGeometry target_;
  RouteGeometry route_;
  CameraModel camera_;
  int vehicle_body_ = -1, camera_id_ = -1, platform_site_ = -1, cart_body_ = -1;
  int rotor_sites_[6] = {-1, -1, -1, -1, -1, -1};
  int vehicle_qpos_ = -1, vehicle_qvel_ = -1;
  int cart_qpos_[3] = {-1, -1, -1}, cart_dof_[3] = {-1, -1, -1};
  int deck_body_ = -1, deck_qpos_[3] = {-1, -1, -1}, deck_dof_[3] = {-1, -1, -1};
  std::uint64_t ground_seed_ = 0;
  std::set<std::string> generated_;  ///< textures World filled from its own generators
  std::set<std::string> released_;   ///< of those, the ones whose pages went back
  // Finds models/cart_deck.xml's deck body and joints (throws ConfigError naming `file`).
  void find_deck_joints(const std::string& file);
  // Fills texture `name` (target_tex or ground_tex) from its generator.
  void generate_texture(const std::string& name);
  // Copies a BGR image into the model's pixels of texture `name` (checks the size).
  void write_texture(const std::string& name, const cv::Mat& bgr);
};

// The procedural ground texture: asphalt-like value noise with patches (non-uniform), BGR.
cv::Mat make_ground_texture(int size_px, std::uint64_t seed);

}  // namespace lander::sim
