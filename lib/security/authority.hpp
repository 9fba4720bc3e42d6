// A receiver's command-authority settings, read from its `authority:` config
// section (docs/security.md):
//   authority:
//     key_file: /etc/harvest/robot.key   # relative paths: to the config file
//     controller: servo-controller       # the one sender obeyed for motion
//     operators: operator                # senders obeyed for e-stop clear and RESET_FAULT (comma-separated)
//     max_age_ms: 1000                   # oldest signing time accepted
//     max_ahead_ms: 100                  # sender clock ahead of the receiver
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "security/auth.hpp"

namespace harvest::security {

struct AuthorityConfig {
  std::filesystem::path key_file;
  std::string controller;
  std::vector<std::string> operators;
  rt::Micros max_age_us = 1 * rt::kSecond;
  rt::Micros max_ahead_us = 100 * rt::kMilli;

  // Throws config::Error naming the key when a value is missing or wrong.
  static AuthorityConfig from_config(const config::Node& authority);

  Policy controller_policy() const { return Policy{{controller}, max_age_us, max_ahead_us}; }
  Policy operator_policy() const { return Policy{operators, max_age_us, max_ahead_us}; }
};

// The key for a receiver on `bus` (a CAN bus string, or empty for none): the
// key file, loaded; a sim key on a real bus (socketcan) is refused, since the
// sim key sits in every build directory and test.
Key load_key_for_bus(const std::filesystem::path& key_file, const std::string& bus);

}  // namespace harvest::security
