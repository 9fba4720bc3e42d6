// A per-robot command key: 32 random bytes in a file only its owner can read.
// The file says what it is for: a "sim" key is made by the build for the
// simulator sets and tests, a "robot" key by harvest-keygen for one robot; a
// link on a real bus refuses a sim key (docs/security.md).
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace harvest::security {

constexpr std::size_t kKeyBytes = 32;  // crypto_auth_KEYBYTES
constexpr std::size_t kMacBytes = 32;  // crypto_auth_BYTES

enum class KeyKind { sim, robot };

struct Key {
  std::array<uint8_t, kKeyBytes> bytes{};
  KeyKind kind = KeyKind::robot;

  // First 8 hex digits of a hash of the key: names a key in logs and in the
  // recorded configuration without revealing it.
  std::string id() const;
};

// A fresh random key (libsodium's CSPRNG).
Key generate_key(KeyKind kind);

// The simulator's key: the same 32 bytes on every machine (a hash of a fixed
// text), so reference logs replay byte-identically on any clone. It is public
// by construction and authenticates nothing against an attacker who reads
// this code: simulator sets use it to run the same signing and checking code
// as the robot, and a robot link on a real bus refuses it (AuthorityConfig::load).
Key sim_key();

// Reads a key file; throws std::runtime_error naming the file and the fault
// (missing, unreadable, malformed, wrong length, or readable by group/others).
Key load_key(const std::string& path);

// Writes a key file with mode 0600. Refuses to overwrite an existing file
// unless overwrite is set (a robot's key is replaced on purpose only).
void write_key(const std::string& path, const Key& key, bool overwrite = false);

const char* to_string(KeyKind kind);

}  // namespace harvest::security
