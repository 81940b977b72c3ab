// Rigid-body hexarotor, moving platform, synthetic vision and the closed-loop harness.
#include "hex_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace lander::ctl::test {
namespace {
constexpr double kDeg = M_PI / 180.0;

// Quaternion of the rotation vector phi (exponential map).
Eigen::Quaterniond exp_quat(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  if (a < 1e-12) return Eigen::Quaterniond(1, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z());
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, phi / a));
}

// Three normal draws times `sigma` as (x, y, z), z drawn first and x last: the order GCC
// evaluated the former Vector3d(n01(rng), n01(rng), n01(rng)) arguments in (C++ leaves it
// unspecified; clang goes the other way), so the noise is the same with either compiler.
Eigen::Vector3d draw_xyz(std::normal_distribution<double>& n01, std::mt19937& rng, double sigma) {
  const double z = n01(rng), y = n01(rng), x = n01(rng);
  return Eigen::Vector3d(sigma * x, sigma * y, sigma * z);
}
}  // namespace

HexModel::HexModel(const HexModelParams& p) : p_(p) { reset_hover(Eigen::Vector3d::Zero()); }

void HexModel::reset_hover(const Eigen::Vector3d& p_W, double yaw_rad) {
  p = p_W;
  v.setZero();
  omega_B.setZero();
  q = Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
  const double w_hover = std::sqrt(p_.mass_kg * p_.gravity_mps2 / (6.0 * p_.k_thrust));
  w.fill(w_hover);
  specific_force_B_ = Eigen::Vector3d(0, 0, p_.gravity_mps2);
  in_contact = false;
}

Eigen::Isometry3d HexModel::X_WB() const {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = q.toRotationMatrix();
  X.translation() = p;
  return X;
}

void HexModel::step(double t_s, double dt, const std::array<double, 6>& w_cmd,
                    const PlatformTruth* platform) {
  // Motors: first-order lag towards the saturated command.
  const double alpha = p_.motor_tau_s > 0 ? 1.0 - std::exp(-dt / p_.motor_tau_s) : 1.0;
  for (int k = 0; k < 6; ++k) {
    const double c = std::clamp(w_cmd[k], 0.0, p_.w_max_radps);
    w[k] += (c - w[k]) * alpha;
  }
  if (in_contact) {
    // Resting on the surface: carried along, reads +g (the platform does not accelerate).
    const Eigen::Vector3d v_s = contact_on_platform ? platform->v_W(t_s + dt) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d c_s = contact_on_platform ? platform->p_W(t_s + dt) : Eigen::Vector3d::Zero();
    p = c_s + contact_p_offset_;
    v = v_s;
    omega_B.setZero();
    specific_force_B_ = q.conjugate() * Eigen::Vector3d(0, 0, p_.gravity_mps2);
    return;
  }
  // Rotor k at azimuth 30 + 60k deg, spin +1 for even k: thrust along z_B, torques
  // r_k x (0, 0, T_k) and the reaction -s_k kQ w^2 about z_B (common vehicle facts).
  double T = 0.0;
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  for (int k = 0; k < 6; ++k) {
    const double az = (30.0 + 60.0 * k) * kDeg;
    const double Tk = p_.k_thrust * w[k] * w[k];
    const Eigen::Vector3d r(p_.arm_m * std::cos(az), p_.arm_m * std::sin(az), p_.rotor_height_m);
    T += Tk;
    tau += r.cross(Eigen::Vector3d(0, 0, Tk));
    tau.z() += -((k % 2 == 0) ? 1.0 : -1.0) * p_.k_torque * w[k] * w[k];
  }
  // Translational dynamics (eq. 19-20 in W) with linear drag; semi-implicit Euler.
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const Eigen::Vector3d g_W(0, 0, -p_.gravity_mps2);
  Eigen::Vector3d wind = p_.wind_W_mps;
  if (p_.gust_amplitude_mps != 0.0 && wind.norm() > 0) {
    wind += wind.normalized() * p_.gust_amplitude_mps * std::sin(2 * M_PI * t_s / p_.gust_period_s);
  }
  const Eigen::Vector3d a =
      (R * Eigen::Vector3d(0, 0, T) - p_.drag_N_per_mps * (v - wind)) / p_.mass_kg + g_W;
  specific_force_B_ = R.transpose() * (a - g_W);
  v += a * dt;
  p += v * dt;
  // Rotational dynamics (eq. 22): J dw/dt = -w x J w + tau.
  const Eigen::Vector3d J = p_.inertia_kgm2;
  const Eigen::Vector3d dw = (tau - omega_B.cross(J.cwiseProduct(omega_B))).cwiseQuotient(J);
  omega_B += dw * dt;
  q = (q * exp_quat(omega_B * dt)).normalized();

  // Contact with the platform top (inside its radius) or the ground.
  const double gear_z = p.z() - p_.gear_height_m;
  bool hit = false, on_platform = false;
  Eigen::Vector3d surface_p = Eigen::Vector3d(p.x(), p.y(), 0.0);
  if (platform) {
    const Eigen::Vector3d c = platform->p_W(t_s + dt);
    const double r = (p - c).head<2>().norm();
    if (r <= platform->radius_m && gear_z <= c.z() && gear_z > c.z() - 0.3) {
      hit = on_platform = true;
      surface_p = c;
    }
  }
  if (!hit && gear_z <= 0.0) hit = true;
  if (hit) {
    in_contact = true;
    contact_on_platform = on_platform;
    contact_t_s = t_s + dt;
    const Eigen::Vector3d v_s = on_platform ? platform->v_W(t_s + dt) : Eigen::Vector3d::Zero();
    contact_offset_W_m = p - surface_p;
    contact_rel_v_W_mps = v - v_s;
    contact_tilt_deg = std::acos(std::clamp((q * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) / kDeg;
    contact_p_offset_ = Eigen::Vector3d(contact_offset_W_m.x(), contact_offset_W_m.y(),
                                        p_.gear_height_m);
    if (!on_platform) contact_p_offset_ = Eigen::Vector3d(p.x(), p.y(), p_.gear_height_m);
  }
}

NavState HexModel::nav(double t_s) const {
  NavState n;
  n.t_s = t_s;
  n.valid = true;
  n.q_WB = q;
  n.p_W_m = p;
  n.v_W_mps = v;
  n.omega_B_radps = omega_B;
  return n;
}

ImuSample HexModel::imu(double t_s) const {
  ImuSample s;
  s.t_s = t_s;
  s.gyro_B_radps = omega_B;
  s.accel_B_mps2 = specific_force_B_;
  return s;
}

SyntheticVision::SyntheticVision(const VisionModelParams& p, const CameraMount& mount,
                                 const CameraModel& cam)
    : p_(p), X_BC_(mount.X_BC()), cam_(cam), rng_(p.seed) {}

void SyntheticVision::update(double t_s, const Eigen::Isometry3d& X_WB,
                             const Eigen::Isometry3d& X_WP) {
  if (t_s + 1e-9 < next_frame_t_) return;
  next_frame_t_ += 1.0 / p_.rate_hz;
  ++frames;
  PlatformObservation obs;
  obs.t_s = t_s;
  const Eigen::Isometry3d X_CW = (X_WB * X_BC_).inverse();
  const Eigen::Isometry3d X_CP = X_CW * X_WP;
  const Eigen::Vector3d pc = X_CP.translation();
  bool ok = pc.z() > 0.05 && pc.norm() < p_.max_range_m;
  if (ok) {
    const double u = cam_.fx_px * pc.x() / pc.z() + cam_.cx_px;
    const double vv = cam_.fy_px * pc.y() / pc.z() + cam_.cy_px;
    ok = u >= p_.margin_px && u <= cam_.width_px - 1 - p_.margin_px && vv >= p_.margin_px &&
         vv <= cam_.height_px - 1 - p_.margin_px;
  }
  if (ok && visible) ok = visible(t_s, X_WB);
  if (ok) {
    std::normal_distribution<double> n01(0.0, 1.0);
    const double sp = p_.pos_noise_floor_m + p_.pos_noise_per_m * pc.norm();
    const Eigen::Vector3d dp = draw_xyz(n01, rng_, sp);
    const double sr = p_.rot_noise_deg * kDeg;
    const Eigen::Vector3d dr = draw_xyz(n01, rng_, sr);
    obs.detected = true;
    obs.keyframe = true;
    obs.rings_identified = 7;
    obs.X_CP = X_CP;
    obs.X_CP.linear() = X_CP.linear() * exp_quat(dr).toRotationMatrix();
    obs.X_CP.translation() = pc + dp;
    ++detections;
  }
  queue_.emplace_back(t_s + p_.latency_s, obs);
}

std::vector<PlatformObservation> SyntheticVision::deliver(double t_s) {
  std::vector<PlatformObservation> out;
  while (!queue_.empty() && queue_.front().first <= t_s + 1e-9) {
    out.push_back(queue_.front().second);
    queue_.pop_front();
  }
  return out;
}

std::string LandingRunResult::describe() const {
  std::ostringstream os;
  for (const ModeTransition& tr : transitions) {
    os << "  t=" << tr.t_s << " " << to_string(tr.from) << " -> " << to_string(tr.to) << ": "
       << tr.reason << "\n";
  }
  os << "  contact=" << contact << " on_platform=" << on_platform << " landed=" << landed
     << " t=" << contact_t_s << " offset=" << touchdown_offset_m
     << " rel_speed=" << touchdown_rel_speed_mps << " tilt=" << touchdown_tilt_deg
     << " max_tilt=" << max_tilt_deg << " frames=" << vision_frames
     << " detections=" << vision_detections << "\n";
  return os.str();
}

LandingRunResult run_landing(const LandingRunConfig& cfg) {
  HexModel model(cfg.model);
  model.reset_hover(cfg.start_W_m);
  const CameraMount mount;
  LandingController ctl(cfg.controller, mount);
  SyntheticVision vision(cfg.vision, mount, CameraModel{});
  vision.visible = cfg.visible;
  RotorCommand cmd;
  cmd.w_radps = model.w;
  LandingRunResult res;
  std::mt19937 nav_rng(cfg.nav_noise.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const NavNoiseParams& nn = cfg.nav_noise;
  Eigen::Vector3d pos_bias = Eigen::Vector3d::Zero();
  auto white3 = [&](double sigma) { return draw_xyz(n01, nav_rng, sigma); };
  const int steps = static_cast<int>(cfg.max_time_s / cfg.physics_dt_s);
  for (int i = 0; i < steps; ++i) {
    const double t = i * cfg.physics_dt_s;
    Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
    X_WP.translation() = cfg.platform.p_W(t);
    vision.update(t, model.X_WB(), X_WP);
    if (i % cfg.inner_every == 0) {
      for (const PlatformObservation& obs : vision.deliver(t)) ctl.on_vision(obs);
      if (cfg.feed) cfg.feed(t, model, ctl);
      NavState nav = model.nav(t);
      const double dt_ctl = cfg.physics_dt_s * cfg.inner_every;
      pos_bias += white3(nn.pos_walk_m_per_sqrt_s * std::sqrt(dt_ctl));
      nav.p_W_m += pos_bias + white3(nn.pos_white_m);
      nav.v_W_mps += white3(nn.vel_white_mps);
      nav.q_WB = (nav.q_WB * exp_quat(white3(nn.att_white_deg * kDeg))).normalized();
      nav.omega_B_radps += white3(nn.gyro_white_radps);
      ImuSample imu = model.imu(t);
      imu.gyro_B_radps = nav.omega_B_radps;
      cmd = ctl.step(t, nav, imu);
      if (cfg.on_step) cfg.on_step(t, model, ctl);
    }
    model.step(t, cfg.physics_dt_s, cmd.w_radps, &cfg.platform);
    if (!model.in_contact) {
      const double tilt =
          std::acos(std::clamp((model.q * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) / kDeg;
      res.max_tilt_deg = std::max(res.max_tilt_deg, tilt);
    }
    if (model.in_contact && (ctl.landed() || t > model.contact_t_s + 2.0)) break;
  }
  res.contact = model.in_contact;
  res.on_platform = model.contact_on_platform;
  res.landed = ctl.landed();
  res.contact_t_s = model.contact_t_s;
  res.touchdown_offset_m = model.contact_offset_W_m.head<2>().norm();
  res.touchdown_rel_speed_mps = model.contact_rel_v_W_mps.norm();
  res.touchdown_tilt_deg = model.contact_tilt_deg;
  res.transitions = ctl.transitions();
  res.vision_frames = vision.frames;
  res.vision_detections = vision.detections;
  return res;
}

}  // namespace lander::ctl::test
