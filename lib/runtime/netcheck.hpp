// Start-up self-check of the host network for LCM: LCM uses UDP multicast
// and silently drops messages larger than the socket receive buffer allows,
// so a badly set-up host loses camera frames without a word.
#pragma once

#include <string>
#include <vector>

namespace harvest::rt {

struct NetFinding {
  bool ok;
  std::string what;    // what was checked and found
  std::string fix;     // what to do about it (empty when ok)
};

// Recommended minimum for net.core.rmem_max: two 640x480 BGR frames in flight.
constexpr long kRecommendedRmem = 8 * 1024 * 1024;

// Reads /proc (paths injectable for tests).
std::vector<NetFinding> check_network(const std::string& proc_root = "/proc");

}  // namespace harvest::rt
