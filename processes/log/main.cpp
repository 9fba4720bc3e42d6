// harvest-log: see lib/logtools/log_cli.hpp and docs/log-tools.md.
#include "logtools/log_cli.hpp"

int main(int argc, char** argv) { return harvest::logtools::log_main(argc, argv); }
