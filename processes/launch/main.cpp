// harvest-launch: starts, watches and stops a process set (docs/launcher.md).
#include "launch/launch_cli.hpp"

int main(int argc, char** argv) { return harvest::launch::launch_main(argc, argv); }
