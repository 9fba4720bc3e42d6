// Why a regenerated message has no partner in the recording, told from the
// logs alone (harvest-replay with the log's own nodes, docs/replay.md): the
// live node had stopped or not started, its input is not in the recording or
// came before the replay's start, or (for nodes that answer every camera
// frame) the live node dropped the frame. What the logs cannot explain stays
// unexplained, and the channel a DIFF.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "logtools/compare.hpp"
#include "runtime/log_io.hpp"

namespace harvest::logtools {

// Fills only_recorded_why / only_replayed_why of every channel of `report`.
// `recording`: the whole input log; `regenerated`: the channels the replay
// published; `replay_start`: the log time the replay began at.
void explain_unmatched(CompareReport& report, const std::vector<rt::LogRecord>& recording,
                       const std::set<std::string>& regenerated, int64_t replay_start);

}  // namespace harvest::logtools
