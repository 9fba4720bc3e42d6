#include <gtest/gtest.h>

#include <fstream>

#include "geometry/envelope.hpp"
#include "test_support.hpp"

namespace harvest::geometry {
namespace {

const std::string kWhole =
    "workspace: {min: [-0.9, 0.3, -1.1], max: [0.7, 1.3, 0.3]}\n"
    "max_linear_speed: 0.381\nmax_angular_speed: 1.5708\n"
    "max_linear_acceleration: 1.0\nmax_angular_acceleration: 3.0\n";

std::string error_of(const std::string& text) {
  try {
    Envelope::from_yaml(config::Document::load_string(text, "envelope.yaml").root());
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(Envelope, ShippedFileLoads) {
  auto doc = config::Document::load_file("config/arm/envelope.yaml");
  const Envelope e = Envelope::from_yaml(doc.root());
  doc.check_unused();
  EXPECT_EQ(e.min, Eigen::Vector3d(-0.9, 0.3, -1.1));
  EXPECT_EQ(e.max, Eigen::Vector3d(0.7, 1.3, 0.3));
  EXPECT_EQ(e.max_linear_speed, 0.381);
  EXPECT_EQ(e.max_angular_speed, 1.5708);
  EXPECT_EQ(e.max_linear_acceleration, 1.0);
  EXPECT_EQ(e.max_angular_acceleration, 3.0);
}

// One source: no reader fills in a missing limit with a default of its own.
TEST(Envelope, EveryKeyIsRequired) {
  EXPECT_EQ(error_of(kWhole), "");
  for (const std::string key :
       {"max_linear_speed", "max_angular_speed", "max_linear_acceleration", "max_angular_acceleration"}) {
    std::string text = kWhole;
    text.erase(text.find(key), text.find('\n', text.find(key)) - text.find(key) + 1);
    const std::string e = error_of(text);
    EXPECT_NE(e.find(key), std::string::npos) << key << ": " << e;
    EXPECT_NE(e.find("required"), std::string::npos) << e;
  }
  EXPECT_NE(error_of("max_linear_speed: 0.381").find("workspace"), std::string::npos);
}

TEST(Envelope, BadBoxesAndLimitsAreRefused) {
  std::string flat = kWhole;
  flat.replace(flat.find("max: [0.7"), 9, "max: [-0.9");
  EXPECT_NE(error_of(flat).find("workspace.max: expected greater than min on every axis"), std::string::npos)
      << error_of(flat);
  std::string slow = kWhole;
  slow.replace(slow.find("0.381"), 5, "0.005");  // below the link's minimum goal speed
  EXPECT_NE(error_of(slow).find("max_linear_speed"), std::string::npos) << error_of(slow);
}

TEST(Envelope, AMisspeltKeyInTheFileIsRefusedNamingIt) {
  harvest::testing::TempDir dir;
  std::ofstream(dir / "envelope.yaml") << kWhole << "max_linear_sped: 0.2\n";
  const auto root = config::Document::load_string("envelope: " + (dir / "envelope.yaml").string());
  try {
    Envelope::from_config(root.root(), {"envelope", "unused.yaml"});
    FAIL() << "accepted";
  } catch (const config::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("envelope: expected a readable robot envelope"), std::string::npos) << what;
    EXPECT_NE(what.find("max_linear_sped"), std::string::npos) << what;
  }
}

TEST(Envelope, ContainsBoxIncludesItsFacesOnly) {
  const Envelope e;  // the shipped numbers
  EXPECT_TRUE(e.contains_box(e.min, e.max));
  EXPECT_TRUE(e.contains_box({-0.5, 0.5, -0.5}, {0.5, 1.0, 0.0}));
  EXPECT_FALSE(e.contains_box({-0.9, 0.3, -1.1}, {0.8, 1.3, 0.3}));  // x beyond
  EXPECT_FALSE(e.contains_box({-0.9, 0.3, -1.1}, {0.7, 1.4, 0.3}));  // y beyond
  EXPECT_FALSE(e.contains_box({-1.0, 0.3, -1.1}, {0.7, 1.3, 0.3}));  // x below
}

}  // namespace
}  // namespace harvest::geometry
