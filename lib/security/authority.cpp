#include "security/authority.hpp"

#include <cstdlib>
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

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

AuthorityConfig AuthorityConfig::from_config(const config::Node& n, unsigned needs) {
  namespace k = authority_keys;
  AuthorityConfig c;
  c.key = n.get(k::key);
  if (c.key.empty()) n.fail("key", "'sim' or a key file (harvest-keygen)");
  if (c.key != kSimKeyName) c.key = n.file_path("key").string();
  c.sender = n.get(k::sender);
  if ((needs & kSender) && c.sender.empty()) n.fail("sender", "this process's sender id (it signs commands)");
  c.controller = n.get(k::controller);
  if ((needs & kController) && c.controller.empty())
    n.fail("controller", "the sender id of the one controller obeyed for motion commands");
  c.operators = split_senders(n.get(k::operators));
  if (c.operators.empty()) n.fail("operators", "one or more sender ids, comma-separated");
  c.max_age_us = n.get(k::max_age_ms) * rt::kMilli;
  c.max_ahead_us = n.get(k::max_ahead_ms) * rt::kMilli;
  return c;
}

config::Section AuthorityConfig::schema(const std::string& path, const std::string& where, unsigned needs) {
  namespace k = authority_keys;
  auto s = config::section(path, where, k::key, k::sender, k::controller, k::operators, k::max_age_ms, k::max_ahead_ms);
  for (auto& key : s.keys)
    if ((key.name == "sender" && (needs & kSender)) || (key.name == "controller" && (needs & kController)))
      key.fallback = "required";
  return s;
}

void refuse_sim_key_on_real_bus(const Key& key, const std::string& bus, const std::string& what) {
  if (key.kind == KeyKind::sim && !bus.empty() && can::parse_bus_spec(bus).kind == can::BusSpec::Kind::kSocketCan) {
    throw std::runtime_error(what + " is a sim key, refused on the real bus " + bus +
                             ": make this robot's key with harvest-keygen (docs/security.md)");
  }
}

std::string default_command_key() {
  const char* env = std::getenv("HARVEST_COMMAND_KEY");
  return env && *env ? env : kSimKeyName;
}

Key load_named_key(const std::string& name) { return name == kSimKeyName ? sim_key() : load_key(name); }

Key AuthorityConfig::load(const std::string& bus) const {
  Key k = load_named_key(key);
  refuse_sim_key_on_real_bus(k, bus, key == kSimKeyName ? "authority.key 'sim'" : "key file " + key);
  return k;
}

Authority::Authority(AuthorityConfig config, const Key& key, const rt::Clock& clock, CommandGate::CountFn count)
    : config_(std::move(config)), key_(key), clock_(&clock), count_(std::move(count)) {
  if (!config_.sender.empty()) signer_.emplace(key_, config_.sender, clock);
}

CommandGate& Authority::gate(const std::string& what, const Policy& policy) {
  auto& g = gates_[what];
  if (!g) g = std::make_unique<CommandGate>(what, Verifier(key_, policy, *clock_), *clock_, count_);
  return *g;
}

std::string Authority::describe() const {
  std::string s = "command key " + key_.id() + " (" + to_string(key_.kind) + ")";
  if (!config_.sender.empty()) s += ", signs as '" + config_.sender + "'";
  if (!config_.controller.empty()) s += ", obeys controller '" + config_.controller + "'";
  s += ", operators " + join(config_.operators);
  return s;
}

}  // namespace harvest::security
