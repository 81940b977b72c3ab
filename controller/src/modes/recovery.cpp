// The recovery mode (seed 000 section 3.3): visual-servo tracking of the platform, the bounded
// final decision (issue 10) and the controlled descent into the cut.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "modes/modes.h"
#include "modes/recovery_decisions.h"

namespace lander::ctl::modes {
namespace {

// Time constant of the low-pass on the platform's vertical velocity fed forward (s): longer
// than the velocity filter's noise (tenths of a second), shorter than the drift of the
// navigation's vertical velocity error (seconds).
constexpr double kPlatformVzFilter_s = 0.5;

std::string ordinal(int n) {
  switch (n) {
    case 1: return "first";
    case 2: return "second";
    case 3: return "third";
    default: return fmt::format("{}th", n);
  }
}

}  // namespace

void RecoveryMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& /*reason*/) {
  h_sp_m_ = c.diag.gear_clearance_m;
  servo_int_.setZero();
  platform_vz_lp_ = c.diag.platform_v_W_mps.z();
  final_t0_s_ = std::numeric_limits<double>::quiet_NaN();
  t0_s_ = k.t_s;
  wide_committed_ = false;
  c.diag.wide_committed = false;
  wide_departures_ = 0;
  wide_left_t_s_ = std::numeric_limits<double>::quiet_NaN();
  deck_window_end_s_ = -std::numeric_limits<double>::infinity();
}

ModeResult RecoveryMode::update(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  if (auto out = exit_check(c, k)) return {Setpoint{}, out};
  deck_moving_ = c.deck_moving();
  // Horizontal speed relative to the platform, straight from vision (the rate of the
  // relative vector); infinite while there are too few fixes for it.
  Eigen::Vector3d v_rel_vision;
  const double rel_speed = c.tracker.relative_velocity(&v_rel_vision) ? horizontal(v_rel_vision)
                                                                      : std::numeric_limits<double>::infinity();
  const bool fresh = c.in_view(k.t_s, L.descent_stale_s);
  start_final_stage(c, k);
  if (auto out = final_decision(c, k, rel_speed, fresh)) return {Setpoint{}, out};
  if (auto out = wide_gate_watch(c, k)) return {Setpoint{}, out};
  // A moving deck's quiescent period, once a step: the cut and the descent both ask it.
  deck_quiescent_ = !deck_moving_ || deck_window(c, k, &deck_state_);
  if (auto cut = cut_check(c, k, fresh)) return {c.hold(k.nav.p_W_m), cut};
  return ModeResult::stay(servo(c, k, rel_speed, fresh));
}

// The target lost, or a large error close to the cart (the gear could catch its edge;
// higher up the servo holds height and catches up): the attempt ends.
std::optional<Transition> RecoveryMode::exit_check(LandingContext& c, const Tick& k) const {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  if (!c.in_view(t_s, L.recovery_loss_timeout_s)) {
    const double loss_age = c.loss_age_s(t_s);
    c.declare_loss(t_s);
    return Transition{Mode::kGoAround,
                      fmt::format("target lost for {:.2f} s in recovery at {:.2f} m above the platform", loss_age,
                                  c.diag.gear_clearance_m),
                      Exit::kEndAttempt};
  }
  const double e_xy = c.diag.horizontal_error_m;
  if (e_xy > L.go_around_error_m && c.diag.gear_clearance_m < L.near_height_m) {
    return Transition{Mode::kGoAround,
                      fmt::format("horizontal error {:.2f} m > {:.2f} m in recovery", e_xy, L.go_around_error_m),
                      Exit::kEndAttempt};
  }
  return std::nullopt;
}

// The decision timer starts the first time below the final hold height in this recovery, or
// after recovery_decision_after_s without getting there.
void RecoveryMode::start_final_stage(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s, h = c.diag.gear_clearance_m;
  if (std::isnan(final_t0_s_) && h < L.final_hold_height_m) {
    final_t0_s_ = t_s;
    c.log_event(t_s, "final_stage",
                fmt::format("below the final hold height {:.2f} m: decision in {:.1f} s", L.final_hold_height_m,
                            L.final_decision_after_s));
  } else if (std::isnan(final_t0_s_) && t_s - t0_s_ >= L.recovery_decision_after_s) {
    // The descent gates not met for this long (gusts): the bounded decision starts here,
    // higher up, as if the final stage had begun.
    final_t0_s_ = t_s;
    c.log_event(t_s, "final_stage",
                fmt::format("{:.1f} s in recovery without going below the final hold height "
                            "{:.2f} m (clearance {:.2f} m, error {:.3f} m): decision in {:.1f} s",
                            t_s - t0_s_, L.final_hold_height_m, h, c.diag.horizontal_error_m,
                            L.final_decision_after_s));
  }
}

// Bounded decision (issue 10): final_decision_after_s into the final stage without a cut,
// the gate widens (widening_final_gate), so the commit comes at the first moment the
// disturbance lets the error below it (the smallest error it offers, not the first within the
// wide gate). Within it the vehicle commits and descends into contact; not within it by the
// end of the window: go-around (or abort).
std::optional<Transition> RecoveryMode::final_decision(LandingContext& c, const Tick& k, double rel_speed,
                                                       bool fresh) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s, e_xy = c.diag.horizontal_error_m;
  const double waited = std::isnan(final_t0_s_) ? 0.0 : t_s - final_t0_s_;
  c.diag.final_stage_s = waited;
  if (std::isnan(final_t0_s_) || wide_committed_ || !(waited >= L.final_decision_after_s)) return std::nullopt;
  const double wide_gate = L.wide_gate_m();
  const FinalGate now = widening_final_gate(L, waited);
  if (fresh && e_xy < now.error_m && rel_speed < now.rel_speed_mps) {
    wide_committed_ = true;
    c.diag.wide_committed = true;
    c.decide(t_s, "committed_wide",
             fmt::format("nominal gate ({:.3f} m, {:.2f} m/s) not met {:.1f} s into the final "
                         "stage; error {:.3f} m < {:.3f} m, relative speed {:.2f} m/s < {:.2f} m/s "
                         "(gate widening to {:.3f} m, {:.2f} m/s)",
                         L.final_descent_error_m, L.final_descent_rel_speed_mps, waited, e_xy, now.error_m,
                         rel_speed, now.rel_speed_mps, wide_gate, L.max_touchdown_rel_speed_mps));
  } else if (waited >= L.final_decision_after_s + L.final_decision_window_s) {
    return Transition{Mode::kGoAround,
                      fmt::format("final gate not met in {:.1f} s of the final stage and not the wide "
                                  "gate ({:.3f} m, {:.2f} m/s) in {:.1f} s more: error {:.3f} m, relative "
                                  "speed {:.2f} m/s",
                                  L.final_decision_after_s, wide_gate, L.max_touchdown_rel_speed_mps,
                                  L.final_decision_window_s, e_xy, rel_speed),
                      Exit::kEndAttempt};
  }
  return std::nullopt;
}

// Committed wide: leaving the wide gate (the safe one) is a balked descent, not yet a
// go-around: the vehicle climbs back to the final hold height and descends again once within
// the gate (a stop-and-go cart that sets off under a committed vehicle is matched again
// within a second or two, where a go-around costs a new approach: envelope default-0107 left
// the gate by 6 mm and was still in its second approach at 60 s). The
// (max_wide_departures + 1)-th departure, or final_decision_window_s outside, ends the attempt.
std::optional<Transition> RecoveryMode::wide_gate_watch(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s, e_xy = c.diag.horizontal_error_m, wide_gate = L.wide_gate_m();
  if (!wide_committed_) return std::nullopt;
  if (!(e_xy > wide_gate)) {
    wide_left_t_s_ = std::numeric_limits<double>::quiet_NaN();
    return std::nullopt;
  }
  if (std::isnan(wide_left_t_s_)) {
    ++wide_departures_;
    if (wide_departures_ > L.max_wide_departures) {
      return Transition{Mode::kGoAround,
                        fmt::format("committed within the wide gate, but the error {:.3f} m left it "
                                    "({:.3f} m) for the {} time",
                                    e_xy, wide_gate, ordinal(wide_departures_)),
                        Exit::kEndAttempt};
    }
    wide_left_t_s_ = t_s;
    c.log_event(t_s, "wide_gate_left",
                fmt::format("error {:.3f} m left the wide gate ({:.3f} m) at clearance {:.2f} m: "
                            "back to the final hold height {:.2f} m until within it again",
                            e_xy, wide_gate, c.diag.gear_clearance_m, L.final_hold_height_m));
  } else if (t_s - wide_left_t_s_ > L.final_decision_window_s) {
    return Transition{Mode::kGoAround,
                      fmt::format("committed within the wide gate; the error left it and was not back "
                                  "within {:.3f} m in {:.1f} s (now {:.3f} m)",
                                  wide_gate, L.final_decision_window_s, e_xy),
                      Exit::kEndAttempt};
  }
  h_sp_m_ = std::max(h_sp_m_, L.final_hold_height_m);
  return std::nullopt;
}

// Touchdown test (seed 000 section 3.3): small horizontal error, steady platform, plus low
// and slow relative to the platform. The cut within the nominal gate is the nominal commit.
std::optional<Transition> RecoveryMode::cut_check(LandingContext& c, const Tick& k, bool fresh) {
  const LandingParams& L = c.p.landing;
  const double h = c.diag.gear_clearance_m, e_xy = c.diag.horizontal_error_m;
  const Eigen::Vector3d v_rel = k.nav.v_W_mps - c.diag.platform_v_W_mps;
  // The fused height above the surface assumes a still surface (its ultrasonic set lags a
  // heaving deck by decimetres): over a moving deck the cut goes on vision's clearance alone.
  const double h_fused = c.altitude.valid && !deck_moving_ ? c.altitude.h_surface_m - L.gear_height_m : h;
  const double cut_gate = wide_committed_ ? L.wide_gate_m() : L.touchdown_error_m;
  const CutTest test = touchdown_test({fresh, h, h_fused, c.diag.skid_drop_m, e_xy, cut_gate, v_rel.norm()}, L);
  if (!test.pass) return std::nullopt;
  // Seed 000's steady platform; on a moving deck instead a quiescent period by its prediction
  // (a rolling deck is never steady).
  std::string platform_state = "platform steady";
  if (deck_moving_) {
    if (!deck_quiescent_) return std::nullopt;
    platform_state = deck_state_;
    c.log_event(k.t_s, "deck_cut", platform_state);
  } else if (std::string unsteady;
             !c.tracker.steady(L.steady_window_s, L.steady_tilt_deg, L.max_platform_tilt_deg, &unsteady)) {
    return std::nullopt;
  }
  std::string why = fmt::format("cut: horizontal error {:.3f} m, clearance {:.3f} m (fused {:.3f} m), lowest "
                                "skid end {:.3f} m (fused {:.3f} m), relative speed {:.2f} m/s, {}",
                                e_xy, h, h_fused, test.lowest_skid_m, test.fused_lowest_skid_m, v_rel.norm(),
                                platform_state);
  if (!wide_committed_) c.decide(k.t_s, "committed_nominal", why);
  Transition cut{Mode::kTouchdown, std::move(why)};
  cut.rerun = false;
  return cut;
}

// A moving deck's quiescent period: the first step that finds one the descent begun now
// meets (LandingContext::deck_quiescent) commits the last centimetres to it, and the commit
// holds until the end predicted then, whatever later fits say: a dash begun is not
// stopped half-way by a refit. `why` gives the period.
bool RecoveryMode::deck_window(LandingContext& c, const Tick& k, std::string* why) {
  if (k.t_s <= deck_window_end_s_) {
    *why = deck_window_why_;
    return true;
  }
  QuiescentWindow w;
  const double lead_s = std::max(0.0, c.diag.gear_clearance_m) / c.p.deck.descent_rate_mps;
  if (!c.deck_quiescent(k.t_s, lead_s, why, &w)) return false;
  deck_window_end_s_ = std::min(w.end_s, k.t_s + lead_s + c.p.deck.window_s);
  deck_window_why_ = *why;
  c.log_event(k.t_s, "deck_window", *why);
  return true;
}

// The deck's predicted vertical speed and acceleration at t_s (the latter a central
// difference of the prediction's rate over kDeckAccelStep_s); not valid unless the deck moves
// and its prediction is trusted.
RecoveryMode::DeckFeedForward RecoveryMode::deck_feed_forward(const LandingContext& c, double t_s) const {
  constexpr double kDeckAccelStep_s = 0.05;
  if (!deck_moving_ || !c.deck.ready()) return {};
  const double vz = c.deck.predict(t_s).vz_mps;
  const double az = (c.deck.predict(t_s + kDeckAccelStep_s).vz_mps - c.deck.predict(t_s - kDeckAccelStep_s).vz_mps) /
                    (2.0 * kDeckAccelStep_s);
  return {true, vz, az};
}

// Visual servo: horizontal setpoint on the platform now, its velocity fed forward; descend at
// the controlled rate only while the horizontal error is small.
Setpoint RecoveryMode::servo(LandingContext& c, const Tick& k, double rel_speed, bool fresh) {
  const LandingParams& L = c.p.landing;
  const NavState& nav = k.nav;
  const double h = c.diag.gear_clearance_m, e_xy = c.diag.horizontal_error_m, dt = k.dt_s;
  DescentInputs in{fresh, wide_committed_, e_xy, rel_speed, h, L.wide_gate_m(), dt, deck_quiescent_, std::nullopt,
                   std::nullopt};
  if (deck_moving_) {
    in.wait_gap_m = c.deck.ready() ? c.p.deck.wait_gap_m : std::max(c.p.deck.wait_gap_m, c.p.deck.unpredicted_gap_m);
    in.final_rate_mps = c.p.deck.descent_rate_mps;
    in.deck_committed = deck_quiescent_;
  }
  const DescentStep d = descend(h_sp_m_, in, L);
  h_sp_m_ = d.clearance_sp_m;
  // A moving deck out of sight: back off to the wait of an unpredicted deck (its height is
  // held at the last fix meanwhile, LandingContext::deck_height_since_fix).
  if (deck_moving_ && !fresh) h_sp_m_ = std::max(h_sp_m_, c.p.deck.unpredicted_gap_m);
  const Eigen::Vector2d e_vec = c.diag.platform_W_m.head<2>() - nav.p_W_m.head<2>();
  const Eigen::Vector2d a_plat = c.tracker.acceleration().head<2>();
  servo_int_ = servo_integral(servo_int_, e_vec, e_xy, c.diag.platform_v_W_mps.head<2>(), a_plat, dt, L);
  Setpoint sp = c.hold(c.diag.platform_W_m);
  sp.p_W_m.head<2>() += servo_int_;
  sp.p_W_m.head<2>() = carrot_setpoint(nav.p_W_m.head<2>(), sp.p_W_m.head<2>(), L.recovery_max_carrot_m);
  sp.p_W_m.z() = nav.p_W_m.z() + (h_sp_m_ - h);
  // The platform velocity is fed forward on all three axes: it is estimated against the
  // dead-reckoned vehicle, so it carries the navigation velocity's error, which then
  // cancels in the velocity loop (a baro/GPS-corrected vertical velocity 0.1 m/s slow made
  // the last 30 cm of descent twice the commanded rate without the vertical term). The
  // vertical part is low-passed: a cart's top does not move vertically, what is left is
  // that slowly changing navigation error, and the filter's noise would reach the thrust.
  platform_vz_lp_ += (c.diag.platform_v_W_mps.z() - platform_vz_lp_) * std::min(1.0, dt / kPlatformVzFilter_s);
  // A moving deck's heave is no slow navigation error: its predicted vertical speed and
  // acceleration now (the fixes' latency made up by the prediction) are fed forward instead.
  const DeckFeedForward deck_ff = deck_feed_forward(c, k.t_s);
  // A deck moving without a prediction yet: the tracker's vertical velocity unfiltered (the
  // filter's 0.5 s lag is a decimetre at the deck's 0.4 m/s) while vision sees it, none
  // without (a heave's velocity carried on is soon wrong).
  const double platform_vz = deck_ff.valid  ? deck_ff.vz_mps
                             : deck_moving_ ? (fresh ? c.diag.platform_v_W_mps.z() : 0.0)
                                            : platform_vz_lp_;
  // Horizontally the constant-velocity filter's velocity, or, with turn_velocity_feed_forward,
  // the acceleration filter's (no lag in a turn).
  const Eigen::Vector2d v_ff =
      L.turn_velocity_feed_forward ? c.tracker.velocity_of_acceleration_filter().head<2>().eval()
                                   : c.diag.platform_v_W_mps.head<2>().eval();
  sp.v_W_mps = Eigen::Vector3d(v_ff.x(), v_ff.y(), platform_vz + d.vz_ff_mps);
  sp.a_W_mps2.z() = deck_ff.az_mps2;
  // The platform's horizontal acceleration fed forward (platform_accel_ff_gain, on by
  // default): a stop-and-go cart's 0.6 m/s^2 is otherwise met only by the velocity loop,
  // ~0.35 s behind the cart: 10-20 cm of error at every start and stop. Nothing of it below
  // platform_accel_ff_deadband_mps2, because the raw acceleration of the fit is noisy (fed
  // forward whole at a constant cart speed it landed about 1 cm wider), all of it from
  // platform_accel_ff_full_mps2 on, a share rising linearly between; the direction kept.
  if (L.platform_accel_ff_gain > 0.0 && fresh) {
    const double share =
        accel_feed_forward_share(a_plat.norm(), L.platform_accel_ff_deadband_mps2, L.platform_accel_ff_full_mps2);
    sp.a_W_mps2.head<2>() = L.platform_accel_ff_gain * share * a_plat;
  }
  return sp;
}

}  // namespace lander::ctl::modes
