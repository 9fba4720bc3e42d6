#include "security/key.hpp"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace harvest::security {
namespace {

constexpr const char* kMagic = "harvest-command-key v1";

void init_sodium() {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
}

std::runtime_error key_error(const std::string& path, const std::string& what) {
  return std::runtime_error("key file " + path + ": " + what);
}

}  // namespace

const char* to_string(KeyKind kind) { return kind == KeyKind::sim ? "sim" : "robot"; }

std::string Key::id() const {
  init_sodium();
  std::array<unsigned char, 16> h{};
  crypto_generichash(h.data(), h.size(), bytes.data(), bytes.size(), nullptr, 0);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (int i = 0; i < 4; ++i) {
    out += hex[h[i] >> 4];
    out += hex[h[i] & 0xf];
  }
  return out;
}

Key generate_key(KeyKind kind) {
  init_sodium();
  Key k;
  k.kind = kind;
  crypto_auth_keygen(k.bytes.data());
  return k;
}

Key sim_key() {
  init_sodium();
  static const std::string kText = "harvest simulator command key v1: public, refused on a real bus";
  Key k;
  k.kind = KeyKind::sim;
  crypto_generichash(k.bytes.data(), k.bytes.size(), reinterpret_cast<const unsigned char*>(kText.data()), kText.size(),
                     nullptr, 0);
  return k;
}

Key load_key(const std::string& path) {
  init_sodium();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw key_error(path, std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw key_error(path, "not a regular file");
  // Anyone who can read the key can command the arm: refuse a shared one.
  if (st.st_mode & (S_IRWXG | S_IRWXO)) {
    std::ostringstream m;
    m << "readable or writable by group/others (mode " << std::oct << (st.st_mode & 0777)
      << "); chmod 600 it, the key commands the arm";
    throw key_error(path, m.str());
  }
  std::ifstream in(path);
  if (!in) throw key_error(path, "cannot be read");
  std::string magic, kind, hexkey, extra;
  std::getline(in, magic);
  in >> kind >> hexkey >> extra;
  if (magic != kMagic) throw key_error(path, std::string("first line is not '") + kMagic + "'");
  Key k;
  if (kind == "sim") {
    k.kind = KeyKind::sim;
  } else if (kind == "robot") {
    k.kind = KeyKind::robot;
  } else {
    throw key_error(path, "kind '" + kind + "' is neither 'sim' nor 'robot'");
  }
  if (!extra.empty()) throw key_error(path, "unexpected text after the key");
  std::size_t len = 0;
  if (hexkey.size() != 2 * kKeyBytes ||
      sodium_hex2bin(k.bytes.data(), k.bytes.size(), hexkey.data(), hexkey.size(), nullptr, &len, nullptr) != 0 ||
      len != kKeyBytes) {
    throw key_error(path, "the key is not " + std::to_string(kKeyBytes) + " bytes of hex");
  }
  return k;
}

void write_key(const std::string& path, const Key& key, bool overwrite) {
  init_sodium();
  int flags = O_WRONLY | O_CREAT | (overwrite ? O_TRUNC : O_EXCL);
  int fd = ::open(path.c_str(), flags, 0600);
  if (fd < 0) throw key_error(path, std::strerror(errno));
  // An existing file kept its old mode through O_TRUNC: tighten it as well.
  ::fchmod(fd, 0600);
  std::array<char, 2 * kKeyBytes + 1> hex{};
  sodium_bin2hex(hex.data(), hex.size(), key.bytes.data(), key.bytes.size());
  std::string text = std::string(kMagic) + "\n" + to_string(key.kind) + " " + hex.data() + "\n";
  bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ok = (::close(fd) == 0) && ok;
  sodium_memzero(hex.data(), hex.size());
  if (!ok) throw key_error(path, "write failed");
}

}  // namespace harvest::security
