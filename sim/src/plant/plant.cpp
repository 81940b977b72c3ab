#include "lander/sim/plant/plant.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "lander/sim/plant/ground_effect.h"
#include "lander/sim/plant/mujoco_errors.h"
#include "loop/fault_hooks.h"

namespace lander::sim {

namespace {

// Beyond this distance from the origin the vehicle state counts as diverged (m).
constexpr double kDivergedRange_m = 1e4;

double wrap_pi(double a) { return std::atan2(std::sin(a), std::cos(a)); }

int require_named(const mjModel* m, mjtObj type, const char* name) {
  const int id = mj_name2id(m, type, name);
  if (id < 0) {
    throw ConfigError(std::string("world model has no ") + mju_type2Str(type) + " named '" + name + "'");
  }
  return id;
}

RotorArray to_rotor_array(const std::vector<double>& v) {
  RotorArray a{};
  for (int k = 0; k < kNumRotors; ++k) a[k] = v.at(k);
  return a;
}

}  // namespace

void apply_light(mjModel* m, const LightParams& L) {
  const int sun = require_named(m, mjOBJ_LIGHT, "sun");
  const Eigen::Vector3d dir = L.sun_dir_W.normalized();
  for (int i = 0; i < 3; ++i) {
    m->light_dir[3 * sun + i] = static_cast<float>(dir[i]);
    m->light_diffuse[3 * sun + i] = static_cast<float>(L.sun_intensity);
    m->vis.headlight.ambient[i] = static_cast<float>(L.ambient);
    m->vis.headlight.diffuse[i] = static_cast<float>(L.headlight);
  }
}

void apply_plant_truth(const Scenario& s, World& world) {
  mjModel* m = world.model();
  mjData* d = world.data();
  const int vb = world.vehicle_body();
  // Vehicle mass and inertia (the MJCF holds the nominal vehicle).
  const VehicleModelParams& vm = s.vehicle.model;
  bool inertia_changed = m->body_mass[vb] != vm.mass_kg;
  for (int i = 0; i < 3; ++i) inertia_changed |= m->body_inertia[3 * vb + i] != vm.inertia_kgm2[i];
  if (inertia_changed) {
    m->body_mass[vb] = vm.mass_kg;
    for (int i = 0; i < 3; ++i) m->body_inertia[3 * vb + i] = vm.inertia_kgm2[i];
    // body_subtreemass and the other derived constants. mj_setConst also recomputes
    // stat.extent and stat.center from the geometry (120 m with the ground plane), which
    // would overwrite world.xml's <statistic extent="10">: the renderer's near plane is
    // znear x extent, so the platform would vanish below 0.6 m. Keep the model's own.
    const mjtNum extent = m->stat.extent;
    mjtNum center[3] = {m->stat.center[0], m->stat.center[1], m->stat.center[2]};
    mj_setConst(m, d);
    m->stat.extent = extent;
    for (int i = 0; i < 3; ++i) m->stat.center[i] = center[i];
  }
  // Camera mount: rotated by the error about B's axes and moved by the offset, in B.
  const int cam = world.camera_id();
  if (!s.camera.mount_error_rad.isZero() || !s.camera.mount_offset_m.isZero()) {
    Eigen::Quaterniond q_B_cam(m->cam_quat[4 * cam], m->cam_quat[4 * cam + 1],
                               m->cam_quat[4 * cam + 2], m->cam_quat[4 * cam + 3]);
    const Eigen::Quaterniond q_err(R_from_rpy(s.camera.mount_error_rad));
    const Eigen::Quaterniond q = (q_err * q_B_cam).normalized();
    m->cam_quat[4 * cam] = q.w();
    m->cam_quat[4 * cam + 1] = q.x();
    m->cam_quat[4 * cam + 2] = q.y();
    m->cam_quat[4 * cam + 3] = q.z();
    for (int i = 0; i < 3; ++i) m->cam_pos[3 * cam + i] += s.camera.mount_offset_m[i];
  }
  // Platform height: the platform box and its frame P move together.
  const int site = world.platform_site();
  const double dz = s.cart.platform_height_m - m->site_pos[3 * site + 2];
  if (dz != 0.0) {
    const int platform = require_named(m, mjOBJ_GEOM, "platform");
    m->geom_pos[3 * platform + 2] += dz;
    m->site_pos[3 * site + 2] += dz;
    // The compiler marks a geom or site placed where its body's frame or inertial frame is
    // (models/cart_deck.xml's platform sits at the deck's centre of mass) and then ignores its
    // pos: moved, it is no longer there.
    m->geom_sameframe[platform] = 0;
    m->site_sameframe[site] = 0;
    if (world.has_deck()) {  // the deck rolls and pitches about the platform's centre
      for (const char* j : {"deck_roll", "deck_pitch"}) m->jnt_pos[3 * require_named(m, mjOBJ_JOINT, j) + 2] += dz;
    }
  }
  // Light.
  const LightParams& L = s.world.light;
  const LightParams nominal;
  const bool light_changed = L.sun_dir_W != nominal.sun_dir_W ||
                             L.sun_intensity != nominal.sun_intensity || L.ambient != nominal.ambient ||
                             L.headlight != nominal.headlight;
  if (light_changed) apply_light(m, L);
  if (s.render.shadows) m->light_castshadow[require_named(m, mjOBJ_LIGHT, "sun")] = 1;
  mj_forward(m, d);
}

Plant::Plant(const Scenario& s, World& world)
    : s_(s),
      world_(world),
      motors_(s.vehicle.model.rotor),
      wind_(s.wind, derive_seed(s.seed, "wind")),
      thrust_scale_(to_rotor_array(s.vehicle.model.thrust_scale)),
      torque_scale_(to_rotor_array(s.vehicle.model.torque_scale)) {
  motors_.set_tau_scale(to_rotor_array(s.vehicle.model.tau_scale));
  const mjModel* m = world.model();
  cart_mass_kg_ = m->body_mass[world.cart_body()];
  cart_yaw_inertia_ = m->body_inertia[3 * world.cart_body() + 2];
  // Initial state: cart on its path (the deck on its motion), vehicle hovering at the start.
  const CartReference ref0 = cart_reference(s.cart, 0.0, &world.route());
  world.set_cart_state(ref0.q, ref0.qd);
  if (s.cart.deck_motion.present()) {
    if (!world.has_deck()) throw ConfigError("cart.deck_motion: the world was loaded without the deck's joints");
    deck_waves_ = sim::deck_waves(s.cart.deck_motion, derive_seed(s.seed, "deck"));
    const DeckReference deck0 = deck_reference(deck_waves_, 0.0);
    world.set_deck_state(deck0.q, deck0.qd);
  }
  Eigen::Isometry3d X_WB0 = Eigen::Isometry3d::Identity();
  X_WB0.linear() = Eigen::AngleAxisd(s.vehicle.start_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X_WB0.translation() = s.vehicle.start_p_W_m;
  world.set_vehicle_state(X_WB0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  world.forward();
  // Hover of the true vehicle (mean rotor; a weak rotor is left to the controller).
  w_hover_ = sim::hover_speed_radps(s.vehicle.model.rotor, m->body_subtreemass[world.vehicle_body()],
                                    -m->opt.gravity[2]);
  RotorArray w0;
  w0.fill(w_hover_);
  motors_.reset(w0);
  v_prev_ = world.v_WB();
  truth_.t_s = 0.0;
  truth_.X_WB = world.X_WB();
  truth_.v_W_mps = world.v_WB();
}

bool Plant::step(int k, const RotorArray& w_cmd, std::string* detail) {
  const mjModel* m = world_.model();
  mjData* d = world_.data();
  const double dt = s_.world.physics_dt_s;
  const double t_s = k * dt, tn = (k + 1) * dt;
  const int vb = world_.vehicle_body();
  // Vehicle forces: motors, per-rotor ground effect and thrust deviation, wind drag.
  motors_.step(w_cmd, dt);
  const Eigen::Isometry3d X_WB = world_.X_WB();
  RotorArray thrust_factor;
  for (int r = 0; r < kNumRotors; ++r) {
    const Eigen::Vector3d p_rotor(d->site_xpos + 3 * world_.rotor_site(r));
    const double h = world_.ray_distance(p_rotor, -Eigen::Vector3d::UnitZ());
    const double ge = h > 0 ? ground_effect_factor(s_.vehicle.model.ground_effect, h) : 1.0;
    thrust_factor[r] = ge * thrust_scale_[r];
  }
  const BodyWrench wr = rotor_wrench(s_.vehicle.model.rotor, motors_.speeds_radps(), thrust_factor,
                                     torque_scale_);
  const Eigen::Vector3d air = wind_.step(dt);
  const Eigen::Vector3d drag_W = drag_force_W(s_.wind, X_WB.linear(), world_.v_WB(), air);
  const Eigen::Vector3d f_W = X_WB.linear() * wr.force_B_N + drag_W;
  const Eigen::Vector3d tau_W = X_WB.linear() * wr.torque_B_Nm;
  for (int i = 0; i < 3; ++i) {
    d->xfrc_applied[6 * vb + i] = f_W[i];
    d->xfrc_applied[6 * vb + 3 + i] = tau_W[i];
  }
  drive_cart(t_s);
  if (world_.has_deck()) drive_deck(t_s);
  const FaultParams& F = s_.faults;
  if (F.diverge_t_s >= 0 && t_s >= F.diverge_t_s && !diverge_injected_) {
    d->qvel[world_.vehicle_dof_adr() + 2] = std::numeric_limits<double>::quiet_NaN();  // test hook
    diverge_injected_ = true;
  }
  // A NaN or runaway state makes MuJoCo warn ("... The simulation is unstable"); our warning
  // handler throws.
  try {
    mj_step(m, d);
  } catch (const MujocoError& e) {
    if (!is_instability_warning(e.what())) throw;
    *detail = fmt::format("{} (at t = {:.3f} s)", e.what(), tn);
    return false;
  }
  update_truth(tn);
  if (!world_.state_finite() || !truth_.X_WB.translation().allFinite() ||
      truth_.X_WB.translation().norm() > kDivergedRange_m) {
    *detail = fmt::format("the vehicle state is not finite or beyond {:.0f} km of the origin at t = {:.3f} s",
                          kDivergedRange_m / 1000.0, tn);
    return false;
  }
  return true;
}

// Cart drive: PD + feed-forward per joint so the cart follows its path whatever lands on it.
// Gains in N/m, N s/m (x, y) and N m/rad, N m s/rad (yaw).
void Plant::drive_cart(double t_s) {
  const mjModel* m = world_.model();
  mjData* d = world_.data();
  const CartReference ref = cart_reference(s_.cart, t_s, &world_.route());
  const Eigen::Vector3d q = world_.cart_q(), qd = world_.cart_qd();
  const double kp[3] = {4000.0, 4000.0, 3000.0}, kd[3] = {1200.0, 1200.0, 500.0};
  const double inertia[3] = {cart_mass_kg_, cart_mass_kg_, cart_yaw_inertia_};
  for (int i = 0; i < 3; ++i) {
    double e = ref.q[i] - q[i];
    if (i == 2) e = wrap_pi(e);
    const double damping = m->dof_damping[world_.cart_dof(i)];
    d->ctrl[i] = inertia[i] * ref.qdd[i] + kp[i] * e + kd[i] * (ref.qd[i] - qd[i]) + damping * ref.qd[i];
  }
}

// Deck drive (motors 3-5 of models/world_deck.xml): the joint's diagonal inertia times the
// reference acceleration, MuJoCo's bias force (gravity, the cart's motion), the joint damping
// and a PD at 5 Hz, critically damped, so a landing vehicle (40 N on a 40 kg deck) sags it by
// 1 mm and tilts it by 0.1 deg.
void Plant::drive_deck(double t_s) {
  const mjModel* m = world_.model();
  mjData* d = world_.data();
  const DeckReference ref = deck_reference(deck_waves_, t_s);
  const Eigen::Vector3d q = world_.deck_q(), qd = world_.deck_qd();
  constexpr double kOmega_radps = 2.0 * M_PI * 5.0;
  for (int i = 0; i < 3; ++i) {
    const int dof = world_.deck_dof(i);
    const double inertia = d->qM[m->dof_Madr[dof]];  // diagonal of the joint-space inertia
    const double kp = inertia * kOmega_radps * kOmega_radps, kd = 2.0 * inertia * kOmega_radps;
    d->ctrl[3 + i] = inertia * ref.qdd[i] + d->qfrc_bias[dof] + m->dof_damping[dof] * ref.qd[i] +
                     kp * (ref.q[i] - q[i]) + kd * (ref.qd[i] - qd[i]);
  }
}

void Plant::update_truth(double tn) {
  const double dt = s_.world.physics_dt_s;
  VehicleTruth& truth = truth_;
  truth.t_s = tn;
  truth.X_WB = world_.X_WB();
  truth.v_W_mps = world_.v_WB();
  truth.omega_B_radps = world_.omega_B();
  truth.a_W_mps2 = (truth.v_W_mps - v_prev_) / dt;
  v_prev_ = truth.v_W_mps;
  truth.h_surface_m = world_.ray_distance(truth.X_WB.translation(), -Eigen::Vector3d::UnitZ());
  if (truth.h_surface_m < 0) truth.h_surface_m = std::numeric_limits<double>::quiet_NaN();
  const double range = world_.ray_distance(truth.X_WB.translation(), -truth.X_WB.linear().col(2));
  truth.range_m = range < 0 ? std::numeric_limits<double>::infinity() : range;
  const RotorParams& rp = s_.vehicle.model.rotor;
  double thrust = 0;
  for (int r = 0; r < kNumRotors; ++r) {
    thrust += thrust_scale_[r] * rotor_thrust_N(rp, motors_.speeds_radps()[r]);
  }
  truth.thrust_fraction = thrust / (kNumRotors * rotor_thrust_N(rp, rp.w_max_radps));
}

}  // namespace lander::sim
