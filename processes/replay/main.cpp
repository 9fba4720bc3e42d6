// harvest-replay: see lib/logtools/replay_tool.hpp and docs/replay.md.
#include "logtools/replay_tool.hpp"

int main(int argc, char** argv) { return harvest::logtools::replay_main(argc, argv); }
