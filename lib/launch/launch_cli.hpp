// Command line of harvest-launch (docs/launcher.md). Kept in the library so
// the integration tests and the process share one implementation.
#pragma once

namespace harvest::launch {

// Exit codes: 0 clean stop (or the --exit-with process's code), 1 a critical
// process failed or the set cannot start (missing executable), 2 bad command
// line or invalid set.
int launch_main(int argc, char** argv);

}  // namespace harvest::launch
