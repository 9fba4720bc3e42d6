// What the controller tells operators: the one-line summary and the
// HARVEST_STATUS message.
#pragma once

#include <optional>
#include <string>

#include "harvest/harvest_status_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/harvest/fruit_ledger.hpp"
#include "servo/harvest/states.hpp"

namespace harvest::servo {

struct StatusInputs {
  State state = State::kIdle;
  bool paused = false;
  bool estop = false;
  std::optional<int> current_fruit;
  std::string note;  // the latest event worth a line (empty: none)
};

// "APPROACH fruit 3 | picked 2, lost 0, unreachable 1, failed grasp 0, aborted 0 | <note>".
std::string summary_line(const StatusInputs& in, const Tally& tally);

// HARVEST_STATUS (the node fills seq and publish time): the summary, the
// tallies, the fixed camera's targets not finished yet (`fixed`, if any),
// and the newest kMaxStatusOutcomes outcomes, so the message stays small on
// a long run. Stamped with the newest robot state (`robot`, if any).
constexpr std::size_t kMaxStatusOutcomes = 50;
harvest_status_t status_message(const StatusInputs& in, const FruitLedger& ledger, const targets_t* fixed,
                                const robot_state_t* robot);

// Where an estimate's depth comes from, in the IR-guidance note ("IR guidance from 452 mm (depth from size)").
const char* depth_source(Fruit::Depth depth);

}  // namespace harvest::servo
