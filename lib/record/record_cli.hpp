// harvest-record's command line and LCM loop (docs/recording-and-replay.md).
#pragma once

namespace harvest::record {

// Records until SIGINT/SIGTERM; exit 0 when stopped, 1 when it cannot record
// (LCM, file, a failed write), 2 on bad options.
int record_main(int argc, char** argv);

}  // namespace harvest::record
