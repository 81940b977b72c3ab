// The mode machine's transition table (lander/controller/landing_controller.h,
// mode_transitions()) and the per-step guard the machine applies every switch through
// (controller/src/modes/transitions.h): every mode's exits, a switch-back within one step
// refused with both reasons, a switch outside the table refused.
#include "../../controller/src/modes/transitions.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <utility>

namespace lander::ctl::modes {
namespace {

const std::vector<Mode> kAllModes = {Mode::kSearch,    Mode::kObserve, Mode::kApproach,
                                     Mode::kRecovery,  Mode::kTouchdown, Mode::kLanded,
                                     Mode::kGoAround,  Mode::kFollowPath, Mode::kAborted};

std::map<Mode, std::set<Mode>> exits_by_mode() {
  std::map<Mode, std::set<Mode>> exits;
  for (const ModeTransitionRule& r : mode_transitions()) exits[r.from].insert(r.to);
  return exits;
}

TEST(ModeTransitions, EveryModesExitsAreTheDesignedOnes) {
  // The table as designed (docs/design/landing-modes.md): a change to it must change this.
  const std::map<Mode, std::set<Mode>> expected = {
      {Mode::kSearch, {Mode::kObserve, Mode::kFollowPath, Mode::kAborted}},
      {Mode::kFollowPath, {Mode::kObserve, Mode::kSearch}},
      {Mode::kObserve, {Mode::kSearch, Mode::kApproach}},
      {Mode::kApproach, {Mode::kRecovery, Mode::kGoAround, Mode::kSearch, Mode::kAborted}},
      {Mode::kRecovery, {Mode::kTouchdown, Mode::kGoAround, Mode::kAborted}},
      {Mode::kTouchdown, {Mode::kLanded, Mode::kGoAround}},
      {Mode::kGoAround, {Mode::kObserve, Mode::kSearch}},
  };
  EXPECT_EQ(exits_by_mode(), expected);
}

TEST(ModeTransitions, OnlyLandedAndAbortedAreTerminalAndEveryModeIsReachable) {
  const auto exits = exits_by_mode();
  for (const Mode m : kAllModes) {
    const bool terminal = m == Mode::kLanded || m == Mode::kAborted;
    EXPECT_EQ(exits.count(m) == 0, terminal) << to_string(m);
  }
  std::set<Mode> reached = {Mode::kSearch};
  for (bool grew = true; grew;) {
    grew = false;
    for (const ModeTransitionRule& r : mode_transitions()) {
      if (reached.count(r.from) && reached.insert(r.to).second) grew = true;
    }
  }
  EXPECT_EQ(reached.size(), kAllModes.size());
}

TEST(ModeTransitions, EveryRuleIsUniqueAndSaysWhatTriggersIt) {
  std::set<std::pair<Mode, Mode>> seen;
  for (const ModeTransitionRule& r : mode_transitions()) {
    EXPECT_TRUE(seen.insert({r.from, r.to}).second) << to_string(r.from) << " -> " << to_string(r.to);
    EXPECT_GT(std::string(r.trigger).size(), 10u) << to_string(r.from) << " -> " << to_string(r.to);
    EXPECT_NE(r.from, r.to);
  }
}

TEST(StepTransitions, AChainOfDistinctModesWithinOneStepIsAdmitted) {
  // A go-around reaching its height out of view, and the search giving up at once.
  StepTransitions guard(12.0, Mode::kGoAround);
  EXPECT_NO_THROW(guard.admit(Mode::kGoAround, Mode::kSearch, "height reached, not in view"));
  EXPECT_NO_THROW(guard.admit(Mode::kSearch, Mode::kAborted, "nothing found"));
}

TEST(StepTransitions, ASwitchBackWithinOneStepIsRefusedWithBothReasons) {
  StepTransitions guard(7.25, Mode::kSearch);
  guard.admit(Mode::kSearch, Mode::kObserve, "target acquired: 3 consecutive keyframes");
  try {
    guard.admit(Mode::kObserve, Mode::kSearch, "target lost for 1.20 s while observing");
    FAIL() << "a switch back to search within the step was admitted";
  } catch (const ModeMachineError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("7.250"), std::string::npos) << what;
    EXPECT_NE(what.find("switch back to search"), std::string::npos) << what;
    EXPECT_NE(what.find("in charge at the step's start"), std::string::npos) << what;
    EXPECT_NE(what.find("target lost for 1.20 s while observing"), std::string::npos) << what;
  }
  // Two modes handing back and forth further down the chain: the reason of the first entry.
  StepTransitions chain(3.0, Mode::kObserve);
  chain.admit(Mode::kObserve, Mode::kApproach, "80 keyframes");
  chain.admit(Mode::kApproach, Mode::kRecovery, "|Diff| small");
  chain.admit(Mode::kRecovery, Mode::kGoAround, "error too large");
  try {
    chain.admit(Mode::kGoAround, Mode::kObserve, "height reached, in view");
    FAIL() << "a return to observe within the step was admitted";
  } catch (const ModeMachineError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("height reached, in view"), std::string::npos) << what;
  }
}

TEST(StepTransitions, ASwitchOutsideTheTableIsRefused) {
  StepTransitions guard(1.0, Mode::kSearch);
  EXPECT_THROW(guard.admit(Mode::kSearch, Mode::kTouchdown, "no such rule"), ModeMachineError);
  StepTransitions from_landed(1.0, Mode::kLanded);
  EXPECT_THROW(from_landed.admit(Mode::kLanded, Mode::kSearch, "nothing leaves landed"), ModeMachineError);
}

}  // namespace
}  // namespace lander::ctl::modes
