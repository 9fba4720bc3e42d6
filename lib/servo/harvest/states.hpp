// The harvest sequence's states and what each one is, in one table: the
// command it sends every tick, its timeout, whether a harvest is under way
// and whether the current fruit is followed in the hand image. The
// transitions are in harvest_machine.cpp (one function per state).
#pragma once

#include <cstdint>

#include "harvest/fruit_outcome_t.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

enum class State {
  kIdle,
  kSelect,
  kOrient,
  kOrientPd,  // ORIENT by the thesis's PD law (orient_law: thesis_pd)
  kAcquire,
  kApproach,
  kReacquire,
  kIrApproach,
  kBackoff,
  kGrasp,
  kDetach,
  kDrop,
  kRelease,
  kRetreat,
  kReturn,
  kHoming,
  kDone,
  kFault,
  kEstop,
};

// What a state commands the arm every tick.
enum class Motion {
  kNone,      // nothing (waiting for a view, or at rest after one STOP)
  kPoseGoal,  // a pose goal, re-sent every tick with the same goal_id until reached, stalled or timed out
  kTwist,     // a tool twist through the speed, acceleration and workspace limits
  kStop,      // STOP every tick
};

// What a state's timeout (or, for a pose goal, a stall) leads to.
enum class Expiry {
  kNone,           // no timeout
  kDone,           // DONE: nothing to select from
  kGiveUp,         // the fruit's outcome is `outcome` "`detail`", then RETURN home
  kGiveUpRetreat,  // ... RETREAT along the tool axis first
  kIrAttempt,      // BACKOFF for another IR attempt while attempts remain, else kGiveUpRetreat
  kFault,          // FAULT "`detail`"
  kMotionBlocked,  // the pose goal did not complete: see HarvestMachine::motion_blocked
};

struct StateSpec {
  State state;
  const char* name;  // as published in HARVEST_STATUS.state
  Motion motion;
  double Timeouts::*timeout;  // the timeouts_s key that bounds the state; nullptr: none
  bool running;               // a harvest is under way: watchdogs run, robot and gripper faults latch
  bool follows_fruit;         // hand detections of the current fruit are associated
  bool rests;                 // entering it sends one STOP on the next tick, then nothing
  Expiry expiry;
  int8_t outcome;      // kGiveUp*: the fruit's outcome (fruit_outcome_t)
  const char* detail;  // kGiveUp*, kFault: the outcome's detail / the fault; kDone: the note
};

// The table row of a state.
const StateSpec& spec(State s);
const char* state_name(State s);

// From one twist state to another the twist keeps ramping within the
// acceleration limit; after a pose goal or a stop it starts from rest.
inline bool keeps_twist(State from, State to) {
  return spec(from).motion == Motion::kTwist && spec(to).motion == Motion::kTwist;
}

}  // namespace harvest::servo
