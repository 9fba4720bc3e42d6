// harvest-sim-frames SCENARIO.yaml... --out DIR: rendered frames in the field look with exact fruit boxes,
// written as the DeepFruits photos are (DIR/images, DIR/boxes.csv with a `visible` column), for training
// and scoring the learned detector (docs/perception.md "Rendered training frames"). Logic in
// lib/sim/training_frames.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "sim/training_frames.hpp"

using namespace harvest;

int main(int argc, char** argv) {
  std::vector<std::string> scenarios;
  std::string out;
  sim::TrainingFramesOptions o;
  bool no_fixed = false;
  CLI::App app("Rendered frames with exact fruit boxes for the learned detector", "harvest-sim-frames");
  app.add_option("scenarios", scenarios, "scenario files (each drawn with other seeds and looks)")->required();
  app.add_option("--out", out, "folder to write images/ and boxes.csv into")->required();
  app.add_option("--scenes", o.scenes, "scenes per scenario file")->check(CLI::PositiveNumber);
  app.add_option("--hand-views", o.hand_views, "hand-camera views per scene")->check(CLI::NonNegativeNumber);
  app.add_flag("--no-fixed", no_fixed, "no fixed-camera view");
  app.add_option("--seed", o.seed, "scene k of a file uses seed + k");
  app.add_option("--min-visible", o.min_visible, "fruit less visible are not written")->check(CLI::Range(0.0, 1.0));
  CLI11_PARSE(app, argc, argv);
  o.fixed_view = !no_fixed;
  try {
    std::vector<std::string> rows;
    for (const auto& file : scenarios) {
      const auto more =
          sim::render_training_frames(sim::load_scenario(file), std::filesystem::path(file).stem().string(), o, out);
      rows.insert(rows.end(), more.begin(), more.end());
    }
    std::ofstream csv(std::filesystem::path(out) / "boxes.csv");
    csv << sim::kTrainingFramesHeader << "\n";
    for (const auto& r : rows) csv << r << "\n";
    if (!csv) throw std::runtime_error("cannot write " + out + "/boxes.csv");
    std::cout << rows.size() << " fruit boxes written to " << out << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "harvest-sim-frames: " << e.what() << "\n";
    return 2;
  }
}
