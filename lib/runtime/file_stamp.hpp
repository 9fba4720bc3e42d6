// Wall-clock UTC as YYYYmmdd-HHMMSS, for naming files (recordings, demo
// output folders). Never for anything a node decides: nodes read the
// injected clock (runtime/clock.hpp).
#pragma once

#include <ctime>
#include <string>

namespace harvest::rt {

inline std::string utc_file_stamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

}  // namespace harvest::rt
