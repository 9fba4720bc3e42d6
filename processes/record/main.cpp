// harvest-record: the launcher's recorder (docs/recording-and-replay.md).
#include "record/record_cli.hpp"

int main(int argc, char** argv) { return harvest::record::record_main(argc, argv); }
