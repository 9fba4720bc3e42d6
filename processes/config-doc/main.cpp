// harvest-config-doc: prints the configuration reference (docs/configuration.md)
// from the key declarations in lib/, or checks that a file is up to date.
// A component's keys come in through its schema() here; see config/schema.hpp.
#include <CLI/CLI.hpp>
#include <fstream>
#include <iostream>
#include <sstream>

#include "arm/robot_link_config.hpp"
#include "camera/camera_node.hpp"
#include "config/schema.hpp"
#include "control/tbz_simulation.hpp"
#include "endeffector/bridge_node.hpp"
#include "endeffector/ir_calibration.hpp"
#include "features/nodes.hpp"
#include "geometry/envelope.hpp"
#include "geometry/transform_file.hpp"
#include "kinematics/arm_model.hpp"
#include "launch/set_spec.hpp"
#include "servo/servo_config.hpp"
#include "sim/scenario.hpp"
#include "sim/sim_node.hpp"
#include "simdrive/sim_drives_node.hpp"
#include "vision/detector_node.hpp"
#include "vision/reconstructor.hpp"

namespace {

std::vector<harvest::config::Section> all_sections() {
  using namespace harvest;
  std::vector<config::Section> out;
  const auto add = [&](std::vector<config::Section> s) {
    for (auto& one : s) out.push_back(std::move(one));
  };
  // The arm: link, model, envelope, drives, calibration files.
  add(arm::RobotLinkConfig::schema());
  add(kinematics::ArmModel::schema());
  add(geometry::Envelope::schema());
  add(simdrive::SimDrivesConfig::schema());
  add({geometry::transform_file_schema()});
  // Perception.
  add(camera::CameraConfig::schema());
  add(vision::DetectorNodeConfig::schema());
  add(vision::ReconstructorConfig::schema());
  add(features::FeatureTrackerConfig::schema());
  // Control and the end effector.
  add(servo::ServoConfig::schema());
  add(endeffector::BridgeConfig::schema());
  add({endeffector::IrCurve::schema()});
  add(control::ThesisScenario::schema());
  // Simulation and the launcher.
  add(sim::SimConfig::schema());
  add(sim::Scenario::schema());
  add(launch::set_schema());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Print the configuration reference (docs/configuration.md) from the key declarations"};
  std::string out, check;
  app.add_option("--out", out, "write it to this file instead of standard output");
  app.add_option("--check", check, "compare with this file; exit 1 when it differs");
  CLI11_PARSE(app, argc, argv);
  const std::string md = harvest::config::reference_markdown(all_sections());
  if (!check.empty()) {
    std::ifstream in(check, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in || text.str() != md) {
      std::cerr << check << " is stale: run tools/harvest config-doc\n";
      return 1;
    }
    return 0;
  }
  if (!out.empty()) {
    std::ofstream f(out, std::ios::binary);
    f << md;
    if (!f) {
      std::cerr << "cannot write " << out << "\n";
      return 2;
    }
    return 0;
  }
  std::cout << md;
  return 0;
}
