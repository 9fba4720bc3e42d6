// From verified feature matches to a TBZ measurement.
//
// The matched features change from frame to frame (descriptors are matched
// afresh), so they cannot serve as the thesis's fixed target points O_i
// directly. All verified pairs give the desired -> current homography G; a
// fixed set of anchor points chosen in the desired image (a square around
// the centroid of the matched features, plus that centroid, which is the
// translation point O_1) are mapped through G to the current image. The
// controller then sees the same four-plus-one target points every frame,
// measured with the accuracy of the whole homography.
#pragma once

#include <string>

#include "control/tbz_controller.hpp"

namespace harvest::control {

struct MatchMeasurement {
  bool ok = false;
  std::string message;
  TbzMeasurement measurement;  // anchors; translation point is index 0
  int pairs = 0;
};

// `desired`/`current`: verified pairs (>= 4). `anchors_desired`: anchors in
// the desired image; empty = derived from the pairs (centroid and a square of
// half the pairs' RMS spread) and returned through the output for reuse.
MatchMeasurement measurement_from_matches(const geometry::Points2& desired, const geometry::Points2& current,
                                          geometry::Points2& anchors_desired);

}  // namespace harvest::control
