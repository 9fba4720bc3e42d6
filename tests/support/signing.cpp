#include "signing.hpp"

namespace harvest::testing {

security::AuthorityConfig sim_authority(const std::string& sender, const std::string& controller) {
  security::AuthorityConfig c;
  c.key = security::kSimKeyName;
  c.sender = sender;
  c.controller = controller;
  return c;
}

CommandSigner::CommandSigner(std::string sender, const rt::Clock* clock, const security::Key& key)
    : signer_(key, std::move(sender), clock ? *clock : static_cast<const rt::Clock&>(wall_)) {}

CommandSigner& live_controller() {
  static CommandSigner s(kController);
  return s;
}

CommandSigner& live_operator() {
  static CommandSigner s(kOperator);
  return s;
}

}  // namespace harvest::testing
