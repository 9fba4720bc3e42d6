#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "geometry/transform_file.hpp"

namespace harvest::geometry {
namespace {

Eigen::Isometry3d from_text(const std::string& text, Handedness h) {
  auto doc = config::Document::load_string(text);
  const Eigen::Isometry3d t = read_transform(doc.root(), h);
  doc.check_unused();
  return t;
}

TEST(TransformFile, ReadsRowMajorRotationAndMillimetres) {
  // Rz(90 deg), written as on paper: the child's x axis is the parent's y.
  const Eigen::Isometry3d t =
      from_text("rotation: [0, -1, 0, 1, 0, 0, 0, 0, 1]\ntranslation_mm: [10, -20, 30]\n", Handedness::kProper);
  EXPECT_NEAR((t * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(0.01, 0.98, 0.03)).norm(), 0.0, 1e-12);
}

TEST(TransformFile, RejectsNonRotationsAndReflectionsUnlessAllowed) {
  const std::string mirror = "rotation: [0, 1, 0, 0, 0, 1, -1, 0, 0]\ntranslation_mm: [0, 0, 0]\n";
  EXPECT_NO_THROW(from_text(mirror, Handedness::kReflectionAllowed));
  try {
    from_text(mirror, Handedness::kProper);
    ADD_FAILURE() << "a reflection was accepted as a rotation";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("determinant +1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(from_text("rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1.01]\ntranslation_mm: [0, 0, 0]\n",
                         Handedness::kReflectionAllowed),
               config::Error);
  EXPECT_THROW(from_text("rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n", Handedness::kProper), config::Error);
  EXPECT_THROW(
      from_text("rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1]\ntranslation_mm: [0, 0, 0]\nscale: 2\n", Handedness::kProper),
      config::Error);
}

TEST(TransformFile, WrittenTextRoundTripsAndIsStable) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  t.translation() << 0.0141234567, -0.009, -0.0480000001;
  const std::string text = transform_yaml(t, "measured on a test bench\n\nsecond paragraph");
  EXPECT_EQ(text.rfind("# measured on a test bench\n#\n# second paragraph\nrotation: [", 0), 0u) << text;
  EXPECT_EQ(text, transform_yaml(t, "measured on a test bench\n\nsecond paragraph"));
  const auto file = std::filesystem::temp_directory_path() / ("transform_" + std::to_string(::getpid()) + ".yaml");
  { std::ofstream(file) << text; }
  const Eigen::Isometry3d back = load_transform_file(file, Handedness::kProper);
  std::filesystem::remove(file);
  EXPECT_TRUE(back.matrix().isApprox(t.matrix(), 1e-11));
  // No negative zeros or rounding noise: the identity prints as integers.
  EXPECT_NE(transform_yaml(Eigen::Isometry3d::Identity(), "").find("rotation: [1, 0, 0,"), std::string::npos);
}

}  // namespace
}  // namespace harvest::geometry
