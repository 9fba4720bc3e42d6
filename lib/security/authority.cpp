#include "security/authority.hpp"

#include <sstream>
#include <stdexcept>

#include "can/bus_spec.hpp"

namespace harvest::security {
namespace {

std::vector<std::string> split_senders(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, ',')) {
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    if (b != std::string::npos) out.push_back(item.substr(b, e - b + 1));
  }
  return out;
}

}  // namespace

AuthorityConfig AuthorityConfig::from_config(const config::Node& n) {
  AuthorityConfig c;
  c.key_file = n.file_path("key_file");
  c.controller = n.required<std::string>("controller");
  if (c.controller.empty()) n.fail("controller", "a sender id");
  c.operators = split_senders(n.get<std::string>("operators", "operator"));
  if (c.operators.empty()) n.fail("operators", "one or more sender ids, comma-separated");
  c.max_age_us = n.get<int>("max_age_ms", 1000, {1, 60'000}) * rt::kMilli;
  c.max_ahead_us = n.get<int>("max_ahead_ms", 100, {0, 10'000}) * rt::kMilli;
  return c;
}

Key load_key_for_bus(const std::filesystem::path& key_file, const std::string& bus) {
  Key key = load_key(key_file.string());
  if (key.kind == KeyKind::sim && !bus.empty() && can::parse_bus_spec(bus).kind == can::BusSpec::Kind::kSocketCan) {
    throw std::runtime_error("key file " + key_file.string() + " holds a sim key, refused on the real bus " + bus +
                             ": make this robot's key with harvest-keygen (docs/security.md)");
  }
  return key;
}

}  // namespace harvest::security
