// The modes after the descent: touchdown (motors cut, waiting for contact), landed, the
// go-around and the abort.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl::modes {
namespace {

// Band around the go-around altitude that counts as reached (m): the position loop settles
// within a few centimetres; 0.3 m avoids waiting for the last exponential tail.
constexpr double kGoAroundReachedBand_m = 0.3;

// Go-around and abort: straight up from here to the go-around height above the top (the
// motors restart from idle after a cut).
void climb_out(LandingContext& c, const NavState& nav, Mode from) {
  c.hold_p = nav.p_W_m;
  c.hold_p.z() = std::max(nav.p_W_m.z(), c.platform_z() + c.p.landing.go_around_height_m);
  if (from == Mode::kTouchdown) c.cascade.reset();
}

}  // namespace

void TouchdownMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& reason) {
  cut_t_s_ = k.t_s;
  contact_accum_s_ = 0.0;
  c.log_event(k.t_s, "cut", reason);
}

ModeResult TouchdownMode::update(LandingContext& c, const Tick& k) { return ModeResult::stay(c.hold(k.nav.p_W_m)); }

// After the rotors spun down (free fall reads ~0), a specific force near +g along z_B means
// the vehicle rests on something.
std::optional<Transition> TouchdownMode::detect_contact(const LandingContext& c, double t_s, double dt_s,
                                                        const ImuSample& imu) {
  const LandingParams& L = c.p.landing;
  const double since_cut = t_s - cut_t_s_;
  const double f_z = imu.accel_B_mps2.z();
  if (since_cut >= L.contact_min_time_s && f_z > L.contact_accel_frac * c.p.vehicle.gravity_mps2) {
    contact_accum_s_ += dt_s;
  } else {
    contact_accum_s_ = 0.0;
  }
  if (contact_accum_s_ >= L.contact_confirm_s && since_cut >= L.contact_min_time_s) {
    return Transition{Mode::kLanded,
                      fmt::format("contact: specific force z {:.2f} m/s^2 for {:.3f} s, {:.2f} s after the cut", f_z,
                                  contact_accum_s_, since_cut)};
  }
  if (since_cut > L.contact_timeout_s) {
    return Transition{Mode::kGoAround, fmt::format("no contact {:.2f} s after the motor cut", since_cut)};
  }
  return std::nullopt;
}

void LandedMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& reason) {
  c.diag.contact = true;
  c.diag.contact_t_s = k.t_s;
  c.log_event(k.t_s, "landed", reason);
}

ModeResult LandedMode::update(LandingContext& c, const Tick& k) { return ModeResult::stay(c.hold(k.nav.p_W_m)); }

// The history is kept: the climb follows the predicted platform horizontally so the moving
// cart stays below (the fixes are measurements; only the plan failed).
void GoAroundMode::enter(LandingContext& c, const Tick& k, Mode from, const std::string& /*reason*/) {
  climb_out(c, k.nav, from);
}

ModeResult GoAroundMode::update(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  c.keep_min_height(t_s, k.nav);
  if (std::abs(k.nav.p_W_m.z() - c.hold_p.z()) < kGoAroundReachedBand_m) {
    if (c.tracker.keyframe_streak() >= L.reacquire_frames && c.in_view(t_s, L.loss_timeout_s)) {
      return ModeResult::go(Mode::kObserve, "go-around altitude reached, target in view");
    }
    // Out of view after a go-around for another cause: a loss too (recorded once).
    if (c.reacquisitions.empty() || !std::isnan(c.reacquisitions.back().t_reacquired_s)) c.declare_loss(t_s);
    return ModeResult::go(Mode::kSearch, "go-around altitude reached, target not in view");
  }
  // Keep the moving cart below while climbing.
  Setpoint sp = c.hold(c.hold_p);
  Eigen::Vector2d p, v;
  if (c.predict_platform(t_s, &p, &v)) {
    c.hold_p.head<2>() = p;
    sp.p_W_m.head<2>() = p;
    sp.v_W_mps.head<2>() = v;
  }
  return ModeResult::stay(sp);
}

// Straight up from here to the go-around height above the top, then hold (keep_min_height
// adds the search's minimum height in the mode's first step).
void AbortedMode::enter(LandingContext& c, const Tick& k, Mode from, const std::string& /*reason*/) {
  climb_out(c, k.nav, from);
}

ModeResult AbortedMode::update(LandingContext& c, const Tick& k) {
  c.keep_min_height(k.t_s, k.nav);
  return ModeResult::stay(c.hold(c.hold_p));
}

}  // namespace lander::ctl::modes
