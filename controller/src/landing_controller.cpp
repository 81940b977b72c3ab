// Mode machine of seed 000 section 3 with search / re-acquisition / go-around (see header):
// the modes are the classes of modes/modes.h, their transitions the table of
// modes/transitions.h; this file feeds them the inputs and applies their transitions.
#include "lander/controller/landing_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl {
namespace {

// The platform's broadcast velocity while the broadcast is fresh (telemetry_max_age_s), for
// the tracker's velocity filter to start from.
std::optional<Eigen::Vector3d> broadcast_velocity(const modes::LandingContext& c, double t_s) {
  Eigen::Vector2d p, v;
  if (!c.broadcast_platform(t_s, &p, &v)) return std::nullopt;
  return Eigen::Vector3d(v.x(), v.y(), 0.0);
}

}  // namespace

double accel_feed_forward_share(double a_mps2, double deadband_mps2, double full_mps2) {
  if (!(a_mps2 > deadband_mps2)) return 0.0;
  if (a_mps2 >= full_mps2) return 1.0;
  return (a_mps2 - deadband_mps2) / (full_mps2 - deadband_mps2);
}

const char* to_string(Mode m) {
  switch (m) {
    case Mode::kSearch: return "search";
    case Mode::kObserve: return "observe";
    case Mode::kApproach: return "approach";
    case Mode::kRecovery: return "recovery";
    case Mode::kTouchdown: return "touchdown";
    case Mode::kLanded: return "landed";
    case Mode::kGoAround: return "go_around";
    case Mode::kFollowPath: return "follow_path";
    case Mode::kAborted: return "aborted";
  }
  return "unknown";
}

struct LandingController::Impl {
  Impl(const ControllerParams& params, const CameraMount& mount) : ctx(params, mount) {}

  modes::LandingMode& of(Mode m) {
    switch (m) {
      case Mode::kSearch: return search;
      case Mode::kObserve: return observe;
      case Mode::kApproach: return approach;
      case Mode::kRecovery: return recovery;
      case Mode::kTouchdown: return touchdown;
      case Mode::kLanded: return landed;
      case Mode::kGoAround: return go_around;
      case Mode::kFollowPath: return follow_path;
      case Mode::kAborted: return aborted;
    }
    throw ModeMachineError(fmt::format("unknown mode {}", static_cast<int>(m)));
  }

  // The start of a pass of the machine: the time since the previous pass (0 within a step),
  // the platform's beliefs, the re-acquisition record.
  modes::Tick begin_pass(double t_s, const NavState& nav, double* last_outer_t) {
    const double dt = std::clamp(t_s - *last_outer_t, 0.0, 0.2);
    *last_outer_t = t_s;
    ctx.update_platform_diagnostics(t_s, nav);
    ctx.check_reacquired(t_s);
    ctx.diag.final_stage_s = 0.0;  // recovery sets it
    return modes::Tick{t_s, dt, nav};
  }

  // A transition as its mode asked: a switch, the end of an attempt (to aborted once
  // max_landing_attempts are used) or giving up; the decision logged.
  void take(const modes::Transition& tr, const modes::Tick& k, modes::StepTransitions& guard,
            std::vector<ModeTransition>& log) {
    const LandingParams& L = ctx.p.landing;
    if (tr.exit == modes::Exit::kGiveUp) {
      ctx.decide(k.t_s, "aborted", tr.reason);
      return switch_to(Mode::kAborted, tr.reason, k, guard, log);
    }
    if (tr.exit == modes::Exit::kEndAttempt && ctx.decisions.attempts >= L.max_landing_attempts) {
      const std::string why = fmt::format("{}; {} of {} landing attempts used: abort", tr.reason,
                                          ctx.decisions.attempts, L.max_landing_attempts);
      ctx.decide(k.t_s, "aborted", why);
      return switch_to(Mode::kAborted, why, k, guard, log);
    }
    if (tr.exit == modes::Exit::kEndAttempt) {
      ctx.decide(k.t_s, tr.to == Mode::kGoAround ? "go_around" : "lost", tr.reason);
    }
    switch_to(tr.to, tr.reason, k, guard, log);
  }

  // The switch itself: checked against the table and the step's earlier switches, logged,
  // the next mode's entry actions run.
  void switch_to(Mode to, const std::string& reason, const modes::Tick& k, modes::StepTransitions& guard,
                 std::vector<ModeTransition>& log) {
    guard.admit(ctx.mode, to, reason);
    log.push_back({k.t_s, ctx.mode, to, reason});
    ctx.low_clearance_logged = false;
    of(to).enter(ctx, k, ctx.mode, reason);
    ctx.mode = to;
  }

  modes::LandingContext ctx;
  modes::SearchMode search;
  modes::ObserveMode observe;
  modes::ApproachMode approach;
  modes::RecoveryMode recovery;
  modes::TouchdownMode touchdown;
  modes::LandedMode landed;
  modes::GoAroundMode go_around;
  modes::FollowPathMode follow_path;
  modes::AbortedMode aborted;
};

LandingController::LandingController(const ControllerParams& params, const CameraMount& mount)
    : impl_(std::make_unique<Impl>(params, mount)) {
  impl_->ctx.p.validate();
  mount.validate();
  impl_->ctx.decisions.wide_gate_m = impl_->ctx.p.landing.wide_gate_m();
}

LandingController::~LandingController() = default;
LandingController::LandingController(LandingController&&) noexcept = default;
LandingController& LandingController::operator=(LandingController&&) noexcept = default;

Mode LandingController::mode() const { return impl_->ctx.mode; }
const LandingDecisionLog& LandingController::decision_log() const { return impl_->ctx.decisions; }
const std::vector<Reacquisition>& LandingController::reacquisitions() const { return impl_->ctx.reacquisitions; }
const LandingDiagnostics& LandingController::diagnostics() const { return impl_->ctx.diag; }
const CascadeDiagnostics& LandingController::cascade_diagnostics() const { return impl_->ctx.cascade.diagnostics(); }
const PlatformTracker& LandingController::tracker() const { return impl_->ctx.tracker; }
const ControllerParams& LandingController::params() const { return impl_->ctx.p; }
bool LandingController::route_ended() const { return impl_->ctx.route_ended; }
double LandingController::route_end_t() const { return impl_->ctx.route_end_t_s; }
long LandingController::path_steps() const { return impl_->follow_path.steps(); }
long LandingController::path_target_steps() const { return impl_->follow_path.target_steps(); }
long LandingController::telemetry_received() const { return impl_->ctx.telemetry_received; }
long LandingController::telemetry_search_steps() const { return impl_->ctx.telemetry_search_steps; }

void LandingController::on_vision(const PlatformObservation& obs) {
  if (!plausible_observation(obs)) {
    ++rejected_inputs_;
    return;
  }
  pending_.push_back(obs);
}

void LandingController::on_path(const PathPoints& pts) {
  bool finite = std::isfinite(pts.t_s) && std::isfinite(pts.fx) && std::isfinite(pts.fy) &&
                std::isfinite(pts.cx) && std::isfinite(pts.cy) && pts.fx > 0 && pts.fy > 0;
  for (const Eigen::Vector2d& p : pts.points_px) finite = finite && p.allFinite();
  if (!finite) {
    ++rejected_inputs_;
    return;
  }
  modes::RouteInput& route = impl_->ctx.route;
  if (route.have && pts.t_s < route.points.t_s) return;  // out of order: keep the newer
  route.points = pts;
  route.have = true;
  const int n = static_cast<int>(pts.points_px.size());
  route.streak = n >= impl_->ctx.p.path.enter_min_points ? route.streak + 1 : 0;
  if (n > 0) route.last_t_s = pts.t_s;
}

void LandingController::on_platform_telemetry(const GpsSample& g) {
  if (!g.valid) return;  // the platform's receiver had no fix
  if (!std::isfinite(g.t_s) || !g.p_W_m.allFinite() || !g.v_W_mps.allFinite()) {
    ++rejected_inputs_;
    return;
  }
  std::optional<GpsSample>& broadcast = impl_->ctx.broadcast;
  if (broadcast && g.t_s <= broadcast->t_s) return;  // out of order: keep the newer
  broadcast = g;
  ++impl_->ctx.telemetry_received;
}

void LandingController::on_altitude(const AltitudeEstimate& alt) {
  if (!std::isfinite(alt.z_W_m) || !std::isfinite(alt.vz_W_mps) || !std::isfinite(alt.h_surface_m)) {
    ++rejected_inputs_;
    return;
  }
  if (alt.valid) impl_->ctx.altitude = alt;
}

// One outer step of the mode machine: the mode in charge updates; a transition it takes is
// applied (the next mode entered) and the next mode updates within the same step, each mode
// at most once (StepTransitions refuses a switch-back).
Setpoint LandingController::run_mode_machine(double t_s, const NavState& nav) {
  modes::StepTransitions guard(t_s, impl_->ctx.mode);
  for (;;) {
    const modes::Tick k = impl_->begin_pass(t_s, nav, &last_outer_t_);
    const modes::ModeResult r = impl_->of(impl_->ctx.mode).update(impl_->ctx, k);
    if (!r.next) return r.setpoint;
    impl_->take(*r.next, k, guard, transitions_);
    if (!r.next->rerun) return r.setpoint;
  }
}

// Touchdown, every inner step: contact or its timeout.
void LandingController::detect_contact(double t_s, const ImuSample& imu, const NavState& nav) {
  const double dt = std::max(0.0, t_s - last_inner_t_);
  const std::optional<modes::Transition> next = impl_->touchdown.detect_contact(impl_->ctx, t_s, dt, imu);
  if (!next) return;
  modes::StepTransitions guard(t_s, impl_->ctx.mode);
  impl_->take(*next, modes::Tick{t_s, 0.0, nav}, guard, transitions_);
}

// The first valid navigation state: the search starts here with the heading held.
void LandingController::start(double t_s, const NavState& nav) {
  started_ = true;
  impl_->ctx.yaw_hold_rad = modes::yaw_of(nav.q_WB);
  impl_->search.start(impl_->ctx, t_s);
  impl_->ctx.hold_p = nav.p_W_m;
  last_outer_t_ = t_s;
  last_inner_t_ = t_s;
}

// The cascade's limits for the mode in charge: the tilt while tracking the platform, the
// descent speed near it (recovery), bounded whatever the clearance servo asks.
void LandingController::apply_outer_limits(double t_s) {
  const modes::LandingContext& c = impl_->ctx;
  const Mode m = c.mode;
  const bool tracking = m == Mode::kObserve || m == Mode::kApproach || m == Mode::kRecovery;
  impl_->ctx.cascade.set_tilt_limit_deg(tracking ? c.p.landing.track_max_tilt_deg : c.p.cascade.max_tilt_deg);
  double descent_limit = c.p.cascade.max_vel_down_mps;
  if (m == Mode::kRecovery && c.diag.gear_clearance_m < c.p.landing.final_hold_height_m) {
    descent_limit = c.p.landing.max_descent_final_mps;
  } else if (m == Mode::kRecovery && c.diag.gear_clearance_m < c.p.landing.near_height_m) {
    descent_limit = c.p.landing.max_descent_near_mps;
  }
  // Over a falling deck the limits hold relative to it.
  if (m == Mode::kRecovery && c.deck_moving() && c.deck.ready()) {
    descent_limit += std::max(0.0, -c.deck.predict(t_s).vz_mps);
  }
  impl_->ctx.cascade.set_descent_limit_mps(descent_limit);
}

RotorCommand LandingController::step(double t_s, const NavState& nav, const ImuSample& imu) {
  const bool finite_input = std::isfinite(t_s) && nav.q_WB.coeffs().allFinite() && nav.p_W_m.allFinite() &&
                            nav.v_W_mps.allFinite() && nav.omega_B_radps.allFinite() &&
                            imu.gyro_B_radps.allFinite() && imu.accel_B_mps2.allFinite();
  if (!finite_input) {  // hold the last command rather than feed NaN to the cascade
    ++rejected_inputs_;
    return last_cmd_;
  }
  modes::LandingContext& c = impl_->ctx;
  RotorCommand cmd;
  cmd.t_s = t_s;
  if (nav.valid) {
    c.tracker.add_nav(nav);
    if (c.p.deck.enabled) c.inertial_height.update(t_s, nav, imu, c.p.vehicle.gravity_mps2);
    if (!started_) start(t_s, nav);
  }
  // Vision results in time order, each with the nav state of its own frame time.
  if (started_ && !pending_.empty()) {
    c.tracker.set_velocity_prior(broadcast_velocity(c, t_s));
    std::sort(pending_.begin(), pending_.end(),
              [](const PlatformObservation& a, const PlatformObservation& b) { return a.t_s < b.t_s; });
    for (const PlatformObservation& obs : pending_) {
      const int fixes = c.tracker.total_fixes();
      c.tracker.add_observation(obs);
      if (c.tracker.total_fixes() > fixes) c.feed_deck(c.tracker.latest());
    }
    pending_.clear();
  }
  if (started_ && c.mode == Mode::kTouchdown) detect_contact(t_s, imu, nav);
  if (started_ && nav.valid && c.cascade.outer_due(t_s)) {
    last_sp_ = run_mode_machine(t_s, nav);
    apply_outer_limits(t_s);
    c.cascade.update_outer(t_s, last_sp_, nav);
    c.diag.setpoint = last_sp_;
  }
  c.diag.mode = c.mode;
  last_inner_t_ = t_s;
  const bool cut = c.mode == Mode::kTouchdown || c.mode == Mode::kLanded;
  c.diag.motors_cut = cut;
  cmd.motors_cut = cut;
  if (cut) {
    cmd.w_radps.fill(0.0);
    last_cmd_ = cmd;
    return cmd;
  }
  const MixerOutput out = c.cascade.update_inner(t_s, nav, imu);
  cmd.w_radps = out.w_radps;
  last_cmd_ = cmd;
  return cmd;
}

}  // namespace lander::ctl
