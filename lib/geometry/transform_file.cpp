#include "geometry/transform_file.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "config/schema.hpp"

namespace harvest::geometry {

namespace {
constexpr config::Numbers kRotation{.name = "rotation", .size = 9,
                                    .doc = "row-major rotation (a reflection only where the file allows it)",
                                    .required = true};
constexpr config::Numbers kTranslation{.name = "translation_mm", .size = 3, .unit = "mm", .doc = "translation",
                                       .required = true};
}  // namespace

config::Section transform_file_schema() {
  return config::section("transform_file",
                         "A transform file (config/cameras/hand_eye.yaml, fixed_extrinsic.yaml; harvest-calibrate "
                         "writes them).",
                         kRotation, kTranslation);
}

Eigen::Isometry3d read_transform(const config::Node& n, Handedness handedness) {
  const std::vector<double> r = n.get(kRotation);
  const std::vector<double> t = n.get(kTranslation);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  if ((out.linear() * out.linear().transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6)
    n.fail("rotation", "an orthonormal 3x3 matrix, row-major");
  if (handedness == Handedness::kProper && out.linear().determinant() < 0)
    n.fail("rotation", "a rotation matrix (determinant +1), row-major");
  out.translation() = Eigen::Vector3d(t[0], t[1], t[2]) / 1000.0;
  return out;
}

Eigen::Isometry3d load_transform_file(const std::filesystem::path& file, Handedness handedness) {
  auto doc = config::Document::load_file(file);
  const Eigen::Isometry3d t = read_transform(doc.root(), handedness);
  doc.check_unused();
  return t;
}

namespace {
std::string number(double v) {
  if (std::abs(v) < 5e-13) v = 0.0;  // no "-0" and no 1e-17 noise in the file
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}
}  // namespace

std::string transform_yaml(const Eigen::Isometry3d& transform, const std::string& comment) {
  std::ostringstream out;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) out << (line.empty() ? "#" : "# " + line) << "\n";
  const Eigen::Matrix3d r = transform.linear();
  out << "rotation: [";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out << number(r(i, j)) << (i == 2 && j == 2 ? "]" : (j == 2 ? ",\n           " : ", "));
  out << "\n";
  const Eigen::Vector3d t = transform.translation() * 1000.0;
  out << "translation_mm: [" << number(t.x()) << ", " << number(t.y()) << ", " << number(t.z()) << "]\n";
  return out.str();
}

}  // namespace harvest::geometry
