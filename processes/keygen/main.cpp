// harvest-keygen: makes a command key file (docs/security.md).
//
//   harvest-keygen PATH [--sim] [--force]
// Writes 32 random bytes as a mode-0600 key file and prints its id. A robot
// key (the default) is made once per robot and copied only to the hosts that
// command it; --sim marks a key for simulator sets and tests, which a robot
// link on a real CAN bus refuses. Exit codes: 0 written, 1 cannot write
// (exists without --force, directory missing, ...), 2 bad command line.
#include <CLI/CLI.hpp>
#include <iostream>

#include "security/key.hpp"

int main(int argc, char** argv) {
  CLI::App app{"harvest-keygen: make a command key file"};
  std::string path;
  bool sim = false, force = false;
  app.add_option("path", path, "key file to write")->required();
  app.add_flag("--sim", sim, "a simulator/test key (refused by a link on a real bus)");
  app.add_flag("--force", force, "replace an existing key file");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  namespace sec = harvest::security;
  try {
    sec::Key key = sec::generate_key(sim ? sec::KeyKind::sim : sec::KeyKind::robot);
    sec::write_key(path, key, force);
    std::cout << "wrote " << sec::to_string(key.kind) << " key " << key.id() << " to " << path << "\n";
  } catch (const std::exception& e) {
    std::cerr << "harvest-keygen: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
