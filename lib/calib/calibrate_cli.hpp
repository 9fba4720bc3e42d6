// The command line of harvest-calibrate (docs/calibration.md):
//   harvest-calibrate intrinsics fixed|hand   (--log FILE | --lcm-url URL) -o FILE [--report PNG]
//   harvest-calibrate hand-eye   --intrinsics FILE (--log FILE | --lcm-url URL) -o FILE [--report PNG]
//   harvest-calibrate extrinsics --intrinsics FILE (--log FILE | --lcm-url URL) -o FILE [--report PNG]
//   harvest-calibrate plan hand-eye|extrinsics --intrinsics FILE [--run]   (calib/plan_cli.hpp)
// Views come from the same node over a log (ReplayRunner) or live (LiveRunner).
// Exit codes: 0 written, 1 the views cannot give a trustworthy answer (the
// reason is printed) or a file cannot be read or written, 2 bad command line.
#pragma once

#include <iosfwd>

namespace harvest::calib {

int calibrate_main(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace harvest::calib
