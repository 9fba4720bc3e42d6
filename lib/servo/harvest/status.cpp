#include "servo/harvest/status.hpp"

#include <sstream>

namespace harvest::servo {

std::string summary_line(const StatusInputs& in, const Tally& n) {
  std::ostringstream o;
  o << state_name(in.state);
  if (in.paused) o << " (paused)";
  if (in.estop) o << " [E-STOP latched]";
  if (in.current_fruit) o << " fruit " << *in.current_fruit;
  o << " | picked " << n.picked << ", lost " << n.lost << ", unreachable " << n.unreachable << ", failed grasp "
    << n.failed_grasp << ", aborted " << n.aborted;
  if (!in.note.empty()) o << " | " << in.note;
  return o.str();
}

harvest_status_t status_message(const StatusInputs& in, const FruitLedger& ledger, const targets_t* fixed,
                                const robot_state_t* robot) {
  harvest_status_t s{};
  s.header.frame_id = "base";
  s.header.source_seq = robot ? robot->header.seq : -1;
  s.header.utime = robot ? robot->header.utime : 0;
  s.state = state_name(in.state);
  s.paused = in.paused;
  s.estop = in.estop;
  s.current_fruit_id = in.current_fruit.value_or(-1);
  const Tally& n = ledger.tally();
  s.picked = n.picked;
  s.lost = n.lost;
  s.unreachable = n.unreachable;
  s.failed_grasp = n.failed_grasp;
  s.remaining = 0;
  if (fixed)
    for (const auto& t : fixed->targets)
      if (!ledger.finished(t.fruit_id) && t.fruit_id != in.current_fruit.value_or(-1)) ++s.remaining;
  s.summary = summary_line(in, n);
  const auto& all = ledger.outcomes();
  const std::size_t first = all.size() > kMaxStatusOutcomes ? all.size() - kMaxStatusOutcomes : 0;
  s.outcomes.assign(all.begin() + static_cast<std::ptrdiff_t>(first), all.end());
  s.num_outcomes = static_cast<int32_t>(s.outcomes.size());
  return s;
}

const char* depth_source(Fruit::Depth depth) {
  switch (depth) {  // no default: a new Depth must be named here
    case Fruit::Depth::kSize:
      return "depth from size";
    case Fruit::Depth::kConfirmed:
      return "depth from size, confirmed by the rays' crossing";
    case Fruit::Depth::kCrossing:
      return "depth from the rays' crossing, the size disagreed";
    case Fruit::Depth::kNear:
      return "depth from size, near: the rays' crossing disagreed, set aside";
    case Fruit::Depth::kFixed:
      return "the fixed camera's depth along the hand's ray: its size put it outside";
  }
  return "depth from size";
}

}  // namespace harvest::servo
