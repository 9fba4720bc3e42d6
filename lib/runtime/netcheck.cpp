#include "runtime/netcheck.hpp"

#include <fstream>
#include <sstream>

namespace harvest::rt {

namespace {
long read_long(const std::string& path, long fallback) {
  std::ifstream f(path);
  long v = fallback;
  if (!(f >> v)) return fallback;
  return v;
}
}  // namespace

std::vector<NetFinding> check_network(const std::string& proc_root) {
  std::vector<NetFinding> out;

  // Multicast needs a route: either an explicit 224.0.0.0/4 or a default route.
  bool multicast_route = false, default_route = false;
  std::ifstream routes(proc_root + "/net/route");
  std::string line;
  std::getline(routes, line);  // header
  while (std::getline(routes, line)) {
    std::istringstream ss(line);
    std::string iface, dest, gw, flags, refcnt, use, metric, mask;
    if (!(ss >> iface >> dest >> gw >> flags >> refcnt >> use >> metric >> mask)) continue;
    // /proc/net/route prints addresses as little-endian hex.
    if (dest == "000000E0" && mask == "000000F0") multicast_route = true;
    if (dest == "00000000" && mask == "00000000") default_route = true;
  }
  if (multicast_route)
    out.push_back({true, "multicast route 224.0.0.0/4 present", ""});
  else if (default_route)
    out.push_back({true, "no explicit multicast route; the default route carries LCM multicast", ""});
  else
    out.push_back({false, "no route for multicast (224.0.0.0/4) and no default route: LCM cannot publish",
                   "run `tools/harvest netfix` (adds 224.0.0.0/4 on lo)"});

  const long rmem_max = read_long(proc_root + "/sys/net/core/rmem_max", -1);
  if (rmem_max < 0)
    out.push_back({true, "net.core.rmem_max unreadable; cannot check UDP receive buffers", ""});
  else if (rmem_max < kRecommendedRmem)
    out.push_back({false,
                   "net.core.rmem_max = " + std::to_string(rmem_max) + " bytes; LCM drops large messages (images) " +
                       "silently with receive buffers this small",
                   "run `tools/harvest netfix` (sets net.core.rmem_max and rmem_default to " +
                       std::to_string(kRecommendedRmem) + ")"});
  else
    out.push_back({true, "net.core.rmem_max = " + std::to_string(rmem_max) + " bytes", ""});

  const long rmem_default = read_long(proc_root + "/sys/net/core/rmem_default", -1);
  if (rmem_default >= 0 && rmem_default < 2 * 1024 * 1024)
    out.push_back({false,
                   "net.core.rmem_default = " + std::to_string(rmem_default) +
                       " bytes; lcm-logger and lcm-spy use the default buffer and lose images",
                   "run `tools/harvest netfix`"});
  return out;
}

}  // namespace harvest::rt
