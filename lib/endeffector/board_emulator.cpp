#include "endeffector/board_emulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace harvest::endeffector {

void LinearGripper::advance(Micros now) {
  if (!started_) {
    started_ = true;
    last_ = now;
  }
  const double dt = rt::to_seconds(std::max<Micros>(0, now - last_));
  last_ = now;
  if (state_ != GripState::kClosing && state_ != GripState::kOpening) return;
  const double step = dt / travel_s_;
  const bool closing = target_ < position_;
  // Closing meets the object before the target: hold it there.
  const double stop_at = (closing && object_ > target_) ? object_ : target_;
  position_ = closing ? std::max(stop_at, position_ - step) : std::min(target_, position_ + step);
  if (position_ != stop_at) return;
  if (closing && object_ > target_)
    state_ = GripState::kHolding;
  else if (position_ <= 0.0)
    state_ = GripState::kClosed;
  else if (position_ >= 1.0)
    state_ = GripState::kOpen;
  else
    state_ = GripState::kStopped;
}

void LinearGripper::command(const GripperGoal& goal, Micros now) {
  advance(now);
  force_limit_ = goal.force_n > 0 ? goal.force_n : default_force_;
  switch (goal.kind) {
    case GripperGoal::Kind::kOpen:
      target_ = 1.0;
      break;
    case GripperGoal::Kind::kClose:
      target_ = 0.0;
      break;
    case GripperGoal::Kind::kMove:
      target_ = std::clamp(goal.position, 0.0, 1.0);
      break;
    case GripperGoal::Kind::kStop:
      target_ = position_;
      state_ = GripState::kStopped;
      return;
  }
  state_ = target_ < position_ ? GripState::kClosing : (target_ > position_ ? GripState::kOpening : state_);
}

GripperReading LinearGripper::read(Micros now) {
  advance(now);
  return {state_, position_, state_ == GripState::kHolding ? force_limit_ : 0.0};
}

EmulatorConfig EmulatorConfig::from_config(const config::Node& node) {
  EmulatorConfig c;
  namespace k = board_keys;
  c.ir_rate_hz = node.get(k::ir_rate_hz);
  c.grip_rate_hz = node.get(k::grip_rate_hz);
  c.ir_raw = node.get(k::ir_raw);
  c.full_travel_s = node.get(k::full_travel_s);
  c.default_force_n = node.get(k::default_force_n);
  c.firmware = sanitize_text(node.get(k::firmware));
  return c;
}

BoardEmulator::BoardEmulator(EmulatorConfig config)
    : config_(std::move(config)),
      gripper_(std::make_unique<LinearGripper>(config_.full_travel_s, config_.default_force_n)) {}

void BoardEmulator::new_session(Micros now) {
  parser_.reset();
  out_.clear();
  seq_ = 0;
  next_ir_ = now;
  next_grip_ = now;
}

void BoardEmulator::raise_fault(int32_t code, const std::string& text) {
  fault_code_ = code;
  emit(Fault{code, text});
  next_grip_ = std::numeric_limits<Micros>::min();  // report the fault state at the next produce()
}

void BoardEmulator::emit(Message m) { out_ += encode(Frame{seq_++, std::move(m)}); }

void BoardEmulator::receive(std::span<const uint8_t> bytes, Micros now) {
  parser_.feed(bytes, [&](const Frame& f) { handle(f, now); });
}

void BoardEmulator::handle(const Frame& frame, Micros now) {
  ++commands_;
  if (observer_) observer_(frame, now);
  auto newtons = [](int32_t mn) { return mn * 1e-3; };
  auto accept = [&](const GripperGoal& goal) {
    if (fault_code_ != 0) {
      emit(Ack{frame.seq, 2});
      return;
    }
    gripper_->command(goal, now);
    emit(Ack{frame.seq, 0});
    next_grip_ = now;  // report the new state at once
  };
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, Ping>)
          emit(Pong{m.token, kProtocolVersion, config_.firmware});
        else if constexpr (std::is_same_v<T, Open>)
          accept({GripperGoal::Kind::kOpen, 1.0, 0.0});
        else if constexpr (std::is_same_v<T, Close>)
          accept({GripperGoal::Kind::kClose, 0.0, newtons(m.force_mn)});
        else if constexpr (std::is_same_v<T, Move>)
          accept({GripperGoal::Kind::kMove, m.position_permille * 1e-3, newtons(m.force_mn)});
        else if constexpr (std::is_same_v<T, Stop>)
          accept({GripperGoal::Kind::kStop, 0.0, 0.0});
        else
          emit(Ack{frame.seq, 1});  // telemetry types are not commands
      },
      frame.message);
}

std::string BoardEmulator::produce(Micros now) {
  if (silent_) {  // a hung board: nothing at all comes out
    out_.clear();
    return {};
  }
  {
    const auto period = [](double hz) { return static_cast<Micros>(std::llround(1e6 / hz)); };
    if (now >= next_ir_) {
      emit(IrSample{std::clamp<int32_t>(ir_source_ ? ir_source_(now) : config_.ir_raw, 0, 65535)});
      // Late calls emit one sample, not a burst: a real ADC loop does not catch up either.
      next_ir_ = std::max(next_ir_ + period(config_.ir_rate_hz), now);
    }
    const GripperReading g = gripper_->read(now);
    if (now >= next_grip_ || g.state != last_state_) {
      const GripState state = fault_code_ != 0 ? GripState::kFault : g.state;
      emit(Grip{state, static_cast<int32_t>(std::lround(std::clamp(g.position, 0.0, 1.0) * 1000)),
                static_cast<int32_t>(std::lround(std::max(0.0, g.force_n) * 1000))});
      last_state_ = g.state;
      next_grip_ = std::max(next_grip_ + period(config_.grip_rate_hz), now);
    }
  }
  std::string out;
  out.swap(out_);
  return out;
}

}  // namespace harvest::endeffector
