// Checks a set's site values (launch/set_spec.hpp, SiteSpec) against this
// machine before anything starts, so a field engineer reads one clear line
// per problem instead of a driver's retry loop: a CAN interface exists, is a
// CAN interface and is up; a device node (camera, serial port) exists, is a
// device and can be opened for reading and writing, and if not, which group
// the user lacks (dialout, video). docs/field-setup.md.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "launch/set_spec.hpp"

namespace harvest::launch {

// Where the check looks; injectable so tests can fake interfaces and access.
struct HostProbe {
  std::filesystem::path sys_class_net = "/sys/class/net";
  // Whether this process may open the node for reading and writing
  // (default: access(R_OK | W_OK)).
  std::function<bool(const std::filesystem::path&)> can_open_rw;
};

// One line per problem, "process: site KEY = VALUE: what is wrong; what to do".
// Values that are neither `socketcan:IFACE` nor a /dev path are not checked.
std::vector<std::string> check_site(const SetSpec& set, const std::vector<std::size_t>& selected,
                                    const HostProbe& probe = {});

// The single checks, for tests and other tools.
std::string check_can_interface(const std::string& iface, const std::filesystem::path& sys_class_net);
std::string check_device_node(const std::filesystem::path& node, const std::string& key,
                              const std::function<bool(const std::filesystem::path&)>& can_open_rw);

}  // namespace harvest::launch
