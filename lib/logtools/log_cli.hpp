// The command line of harvest-log (docs/log-tools.md):
//   harvest-log info LOG [--gap-factor F] [--min-gap S]
//   harvest-log export LOG CHANNEL [--format csv|jsonl] [--fields a,b] [-o FILE]
//   harvest-log frames LOG CHANNEL [--detections CHANNEL] --out DIR [--every N] [--max N]
// Exit codes: 0 done, 1 the log cannot be read or the channel is absent, 2 bad command line.
#pragma once

namespace harvest::logtools {

int log_main(int argc, char** argv);

}  // namespace harvest::logtools
