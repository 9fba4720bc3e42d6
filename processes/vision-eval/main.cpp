// harvest-vision-eval LOG --config DETECTOR.yaml --scenario SCENARIO.yaml: runs the fruit detector over a
// log's fixed-camera frames and scores it against the simulator's truth (SIM_TRUTH): per true fruit at
// least --min-visible visible, how many detections lie on it and how far their diameter is from the
// fruit's true apparent diameter (docs/perception.md, "Simulated tree"). Logic in lib/vision/truth_evaluation.
#include <CLI/CLI.hpp>
#include <iostream>

#include "runtime/process_main.hpp"
#include "sim/scenario.hpp"
#include "vision/truth_evaluation.hpp"

using namespace harvest;

int main(int argc, char** argv) {
  std::string log_path, config_file, scenario_file = "config/scenarios/tree.yaml", overlay;
  std::vector<std::string> overrides;
  vision::TruthEvalOptions o;
  CLI::App app("Fixed-camera fruit detector against the simulator's truth", "harvest-vision-eval");
  app.add_option("log", log_path, "LCM log with CAMERA_FIXED and SIM_TRUTH")->required();
  app.add_option("--config,-c", config_file, "detector configuration")->required();
  app.add_option("--set", overrides, "override KEY.PATH=VALUE (repeatable)");
  app.add_option("--scenario", scenario_file, "scenario with the true cameras and fixed_extrinsic_truth");
  app.add_option("--first", o.first, "first frame index");
  app.add_option("--count", o.count, "frames to score");
  app.add_option("--every", o.every, "every n-th frame")->check(CLI::PositiveNumber);
  app.add_option("--min-visible", o.min_visible, "score fruit at least this visible");
  app.add_option("--camera", o.camera, "fixed, or hand (pose from SIM_TRUTH; no visibility: every fruit in view)")
      ->check(CLI::IsMember({"fixed", "hand"}));
  app.add_option("--verbose", o.verbose_frames, "print per-fruit lines for this many frames");
  app.add_option("--crop", o.crop, "with --overlay: also write this sensor-pixel rectangle x y w h, 3x")->expected(4);
  app.add_option("--overlay", overlay, "write frames with detections (cyan) and truth (green) to this folder");
  CLI11_PARSE(app, argc, argv);
  o.overlay_dir = overlay;

  try {
    const auto doc = rt::load_config(config_file, overrides);
    const auto config = vision::DetectorNodeConfig::from_yaml(doc.root());
    // The true camera (the simulator's) at sensor resolution, as the detections are reported.
    const sim::Scenario scenario = sim::load_scenario(scenario_file);
    const sim::CameraSetup& cam = o.camera == "hand" ? scenario.hand_camera : scenario.fixed_camera;
    vision::TrueCamera truth;
    truth.model = cam.model.zoomed(0, 0, cam.model.width, cam.model.height, cam.sensor_width, cam.sensor_height);
    truth.rotation = scenario.fixed_camera_truth.rotation;
    truth.position = scenario.fixed_camera_truth.position;
    if (!overlay.empty()) std::filesystem::create_directories(overlay);
    return vision::run_truth_evaluation(rt::read_log(log_path), config, truth, o, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "harvest-vision-eval: " << e.what() << "\n";
    return 2;
  }
}
