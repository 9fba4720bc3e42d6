#include "launch/site_check.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

namespace harvest::launch {

namespace {

constexpr int kArphrdCan = 280;  // linux/if_arp.h ARPHRD_CAN
constexpr unsigned kIffUp = 0x1;

std::string read_first_line(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::string s;
  std::getline(f, s);
  return s;
}

bool default_can_open_rw(const std::filesystem::path& p) { return access(p.c_str(), R_OK | W_OK) == 0; }

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Where to look for the right name of a missing device.
std::string missing_hint(const std::filesystem::path& node, const std::string& key) {
  const std::string k = lower(key), p = node.string();
  if (k.find("camera") != std::string::npos || p.find("/dev/v4l") == 0 || p.find("/dev/video") == 0)
    return "camera unplugged or named differently: `ls -l /dev/v4l/by-id/` lists the cameras plugged in "
           "(docs/field-setup.md, \"Stable device names\")";
  if (k.find("serial") != std::string::npos || p.find("/dev/serial") == 0 || p.find("/dev/tty") == 0)
    return "serial adapter unplugged or named differently: `ls -l /dev/serial/by-id/` lists the adapters plugged in "
           "(docs/field-setup.md, \"Stable device names\")";
  return "unplugged or named differently (docs/field-setup.md)";
}

std::string user_name() {
  if (const passwd* pw = getpwuid(geteuid())) return pw->pw_name;
  return "uid " + std::to_string(geteuid());
}

bool in_group(gid_t gid) {
  if (getegid() == gid) return true;
  const int n = getgroups(0, nullptr);
  std::vector<gid_t> groups(n > 0 ? n : 0);
  if (n > 0 && getgroups(n, groups.data()) == n)
    for (gid_t g : groups)
      if (g == gid) return true;
  return false;
}

}  // namespace

std::string check_can_interface(const std::string& iface, const std::filesystem::path& sys_class_net) {
  const std::filesystem::path dir = sys_class_net / iface;
  std::error_code ec;
  if (iface.empty() || !std::filesystem::exists(dir, ec))
    return "CAN interface " + iface +
           " does not exist on this machine: no CAN adapter, or its driver is not loaded "
           "(`ip -details link show`; docs/field-setup.md, \"CAN bus\")";
  const std::string type = read_first_line(dir / "type");
  if (!type.empty() && std::stoi(type) != kArphrdCan)
    return iface + " is not a CAN interface (link type " + type + ", CAN is " + std::to_string(kArphrdCan) + ")";
  unsigned flags = 0;
  std::istringstream(read_first_line(dir / "flags")) >> std::hex >> flags;
  if ((flags & kIffUp) == 0)
    return "CAN interface " + iface + " is down: `sudo ip link set " + iface +
           " up type can bitrate 1000000 restart-ms 100` (docs/field-setup.md, \"CAN bus\")";
  if (lower(read_first_line(dir / "operstate")) == "down")
    return "CAN interface " + iface +
           " is up but has no link (bus-off: drives unpowered, wiring or termination; `ip -details -statistics link "
           "show " + iface + "`)";
  return "";
}

std::string check_device_node(const std::filesystem::path& node, const std::string& key,
                              const std::function<bool(const std::filesystem::path&)>& can_open_rw) {
  std::error_code ec;
  const auto link = std::filesystem::symlink_status(node, ec);
  if (!std::filesystem::exists(node, ec)) {
    if (std::filesystem::is_symlink(link))
      return node.string() + " is a link to " + std::filesystem::read_symlink(node, ec).string() +
             ", which does not exist: " + missing_hint(node, key);
    return node.string() + " does not exist: " + missing_hint(node, key);
  }
  if (!std::filesystem::is_character_file(node, ec))
    return node.string() + " is not a device node (expected a character device)";
  if ((can_open_rw ? can_open_rw : default_can_open_rw)(node)) return "";
  struct stat st {};
  std::string owner = "its group";
  bool member = true;
  if (stat(node.c_str(), &st) == 0) {
    if (const group* g = getgrgid(st.st_gid)) owner = std::string("'") + g->gr_name + "'";
    member = in_group(st.st_gid);
  }
  const std::string user = user_name();
  if (!member) {
    std::string name = owner.size() > 2 && owner.front() == '\'' ? owner.substr(1, owner.size() - 2) : "GROUP";
    return "cannot be opened for reading and writing by " + user + ", who is not in group " + owner + " that owns " +
           node.string() + ": `sudo usermod -aG " + name + " " + user + "`, then log in again";
  }
  return "cannot be opened for reading and writing by " + user + " (mode " +
         [&] {
           char buf[8];
           std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(st.st_mode & 07777));
           return std::string(buf);
         }() +
         "; docs/field-setup.md, \"Permissions\")";
}

std::vector<std::string> check_site(const SetSpec& set, const std::vector<std::size_t>& selected,
                                    const HostProbe& probe) {
  std::vector<std::string> problems;
  std::set<std::string> checked;  // a value shared by two processes is reported once
  for (std::size_t i : selected) {
    const std::string& name = set.processes[i].name;
    const auto used = set.site.used_by.find(name);
    if (used == set.site.used_by.end()) continue;
    for (const auto& key : used->second) {
      const std::string& value = set.site.values.at(key);
      if (!checked.insert(key).second) continue;
      std::string problem;
      if (value.rfind("socketcan:", 0) == 0)
        problem = check_can_interface(value.substr(10), probe.sys_class_net);
      else if (value.rfind("/dev/", 0) == 0)
        problem = check_device_node(value, key, probe.can_open_rw);
      if (!problem.empty()) problems.push_back(name + ": site " + key + " = " + value + ": " + problem);
    }
  }
  return problems;
}

}  // namespace harvest::launch
