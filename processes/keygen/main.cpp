// harvest-keygen: makes a command key file (docs/security.md).
//
//   harvest-keygen PATH [--sim] [--force | --keep]
// Writes 32 random bytes as a mode-0600 key file and prints its id. A robot
// key (the default) is made once per robot and copied only to the hosts that
// command it; --sim writes the simulator's well-known key (the same on every
// machine, security::sim_key), which a robot link on a real CAN bus refuses. --keep leaves a valid existing key of that
// kind alone (the build's sim key). Exit codes: 0 written (or kept), 1 cannot
// write (exists without --force, directory missing, an existing file that is
// no key of that kind with --keep, ...), 2 bad command line.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>

#include "security/key.hpp"

int main(int argc, char** argv) {
  CLI::App app{"harvest-keygen: make a command key file"};
  std::string path;
  bool sim = false, force = false, keep = false;
  app.add_option("path", path, "key file to write")->required();
  app.add_flag("--sim", sim, "a simulator/test key (refused by a link on a real bus)");
  auto* force_opt = app.add_flag("--force", force, "replace an existing key file");
  app.add_flag("--keep", keep, "keep an existing key file of this kind (exit 0)")->excludes(force_opt);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  namespace sec = harvest::security;
  const sec::KeyKind kind = sim ? sec::KeyKind::sim : sec::KeyKind::robot;
  try {
    if (keep && std::filesystem::exists(path)) {
      sec::Key old = sec::load_key(path);
      if (old.kind != kind) throw std::runtime_error(path + " holds a " + sec::to_string(old.kind) + " key");
      std::cout << "kept " << sec::to_string(kind) << " key " << old.id() << " in " << path << "\n";
      return 0;
    }
    const sec::Key key = sim ? sec::sim_key() : sec::generate_key(kind);
    sec::write_key(path, key, force);
    std::cout << "wrote " << sec::to_string(key.kind) << " key " << key.id() << " to " << path << "\n";
  } catch (const std::exception& e) {
    std::cerr << "harvest-keygen: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
