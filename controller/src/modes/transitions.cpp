// The transition table and the per-step guard (transitions.h).
#include "modes/transitions.h"

#include <algorithm>

#include <fmt/format.h>

namespace lander::ctl {
namespace {

// Every switch the landing modes make. An attempt that ends (approach, recovery) goes to
// aborted instead once max_landing_attempts are used.
const std::vector<ModeTransitionRule> kTable{
    {Mode::kSearch, Mode::kObserve, "target acquired: reacquire_frames consecutive keyframes"},
    {Mode::kSearch, Mode::kFollowPath, "route in view (path.enter_frames frames), target not acquired"},
    {Mode::kSearch, Mode::kAborted, "nothing found in search_give_up_s"},
    {Mode::kFollowPath, Mode::kObserve, "target acquired while following the route"},
    {Mode::kFollowPath, Mode::kSearch, "route lost for path.route_lost_s"},
    {Mode::kObserve, Mode::kSearch, "target lost for loss_timeout_s"},
    {Mode::kObserve, Mode::kApproach, "observe_frames keyframes, close (or approach_entry_wait_s)"},
    {Mode::kApproach, Mode::kRecovery, "|Diff| < approach_switch_error_m at t_d (or settle timeout)"},
    {Mode::kApproach, Mode::kGoAround, "target lost below go_around_low_height_m"},
    {Mode::kApproach, Mode::kSearch, "target lost higher up"},
    {Mode::kApproach, Mode::kAborted, "target lost, last attempt used"},
    {Mode::kRecovery, Mode::kTouchdown, "cut: low, aligned, slow, platform steady"},
    {Mode::kRecovery, Mode::kGoAround, "target lost, error near the top, final or wide gate not met"},
    {Mode::kRecovery, Mode::kAborted, "the same, last attempt used"},
    {Mode::kTouchdown, Mode::kLanded, "contact: specific force near +g"},
    {Mode::kTouchdown, Mode::kGoAround, "no contact in contact_timeout_s"},
    {Mode::kGoAround, Mode::kObserve, "go-around height reached, target in view"},
    {Mode::kGoAround, Mode::kSearch, "go-around height reached, target not in view"},
};

}  // namespace

const std::vector<ModeTransitionRule>& mode_transitions() { return kTable; }

}  // namespace lander::ctl

namespace lander::ctl::modes {

bool allowed(Mode from, Mode to) {
  const auto& table = mode_transitions();
  return std::any_of(table.begin(), table.end(),
                     [&](const ModeTransitionRule& r) { return r.from == from && r.to == to; });
}

void StepTransitions::admit(Mode from, Mode to, const std::string& reason) {
  if (!allowed(from, to)) {
    throw ModeMachineError(fmt::format("mode machine at t = {:.3f} s: {} -> {} is not in the transition table ({})",
                                       t_s_, to_string(from), to_string(to), reason));
  }
  const auto seen = std::find_if(visited_.begin(), visited_.end(),
                                 [&](const auto& v) { return v.first == to; });
  if (seen != visited_.end()) {
    throw ModeMachineError(fmt::format(
        "mode machine at t = {:.3f} s: switch back to {} within one step: entered for \"{}\", "
        "then {} -> {} for \"{}\"",
        t_s_, to_string(to), seen->second, to_string(from), to_string(to), reason));
  }
  visited_.emplace_back(to, reason);
}

}  // namespace lander::ctl::modes
