// The landing mode machine's transitions: one table (every switch the modes may make, with
// its trigger, as the docs draw it) and the per-step guard the machine applies them through.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "lander/controller/landing_controller.h"

namespace lander::ctl::modes {

// How a transition ends what was going on: a plain switch; the end of a landing attempt
// (to aborted instead once max_landing_attempts are used, the decision logged); giving up
// the landing (decision "aborted").
enum class Exit { kSwitch, kEndAttempt, kGiveUp };

struct Transition {
  Mode to{Mode::kSearch};
  std::string reason;  ///< human-readable cause with the figures that triggered it
  Exit exit{Exit::kSwitch};
  /// false: the setpoint given with the transition stands for this step (the cut's hold),
  /// the new mode runs from the next step.
  bool rerun{true};
};

}  // namespace lander::ctl::modes

namespace lander::ctl {

// A mode machine that broke its own rules: a transition not in the table, or a switch back
// to a mode already left within the same step (two modes handing the vehicle back and forth).
class ModeMachineError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace lander::ctl

namespace lander::ctl::modes {

// Guards the transitions of one outer step: each must be in the table, and no mode may be
// entered twice in one step (the bound: at most one visit per mode).
class StepTransitions {
 public:
  StepTransitions(double t_s, Mode start) : t_s_(t_s), visited_{{start, "in charge at the step's start"}} {}
  // Throws ModeMachineError naming both reasons on a switch-back, or the rule broken.
  void admit(Mode from, Mode to, const std::string& reason);

 private:
  double t_s_;
  std::vector<std::pair<Mode, std::string>> visited_;  // mode and why it was entered
};

// True when (from, to) is in the table.
bool allowed(Mode from, Mode to);

}  // namespace lander::ctl::modes
