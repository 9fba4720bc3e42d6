#include "launch/proc_usage.hpp"

#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace harvest::launch {

ProcUsage read_proc_usage(pid_t pid, const std::filesystem::path& proc) {
  std::ifstream in(proc / std::to_string(pid) / "stat");
  std::string text;
  if (!std::getline(in, text)) return {};
  // The command name (field 2) may hold spaces and parentheses: fields are counted after the last ')'.
  const std::size_t close = text.rfind(')');
  if (close == std::string::npos) return {};
  std::istringstream rest(text.substr(close + 1));
  std::vector<std::string> f;  // f[0] is field 3 (state)
  for (std::string t; rest >> t;) f.push_back(t);
  if (f.size() < 22) return {};
  try {
    ProcUsage u;
    u.cpu_ticks = std::stoll(f[11]) + std::stoll(f[12]);                            // fields 14, 15: utime, stime
    u.rss_bytes = std::stoll(f[21]) * static_cast<int64_t>(sysconf(_SC_PAGESIZE));  // field 24: rss [pages]
    return u;
  } catch (const std::exception&) {
    return {};
  }
}

double ticks_per_second() { return static_cast<double>(sysconf(_SC_CLK_TCK)); }

double cpu_percent(const ProcUsage& before, const ProcUsage& after, double seconds) {
  if (before.cpu_ticks < 0 || after.cpu_ticks < before.cpu_ticks || seconds <= 0) return -1;
  return 100.0 * static_cast<double>(after.cpu_ticks - before.cpu_ticks) / ticks_per_second() / seconds;
}

}  // namespace harvest::launch
