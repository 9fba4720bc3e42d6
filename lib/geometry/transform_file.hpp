// A rigid transform in YAML: the form extrinsic calibrations take
// (config/cameras/hand_eye.yaml, config/cameras/fixed_extrinsic.yaml), read by
// the processes and written by harvest-calibrate (docs/calibration.md).
//
//   rotation: [r00, r01, r02, r10, r11, r12, r20, r21, r22]   # row-major
//   translation_mm: [x, y, z]
//
// It places a child frame in a parent frame: p_parent = R p_child + t.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <string>

#include "config/config.hpp"
#include "config/schema.hpp"

namespace harvest::geometry {

enum class Handedness {
  kProper,             // a rotation (determinant +1)
  kReflectionAllowed,  // also an orthogonal matrix of determinant -1 (the thesis's eq. 4-1)
};

// Reads `rotation` and `translation_mm` from a mapping. Throws config::Error
// naming the key when the rotation is not orthonormal (to 1e-6) or has the
// wrong handedness.
Eigen::Isometry3d read_transform(const config::Node& node, Handedness handedness);

// Loads a whole file holding only that mapping (unknown keys are errors).
// The keys of a transform file, for the reference.
config::Section transform_file_schema();

Eigen::Isometry3d load_transform_file(const std::filesystem::path& file, Handedness handedness);

// The YAML text of a transform, each line of `comment` as a leading "# "
// comment. Numbers are printed with 12 significant digits, so a transform
// round-trips to 1e-12 and the same transform always gives the same text.
std::string transform_yaml(const Eigen::Isometry3d& transform, const std::string& comment);

}  // namespace harvest::geometry
