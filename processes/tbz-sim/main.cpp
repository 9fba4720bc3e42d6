// harvest-tbz-sim: the teach-by-zooming simulation of thesis section 5.6.2.
// Writes errors.csv and features.csv, optional PNG figures like 5-5..5-9,
// and prints one JSON summary line on stdout. See docs/teach-by-zooming.md.
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "control/tbz_simulation.hpp"
#include "runtime/process_main.hpp"

int main(int argc, char** argv) {
  namespace ctl = harvest::control;
  CLI::App app{"Teach-by-zooming simulation (thesis section 5.6.2)"};
  std::string config_file, out_dir, plots_dir;
  std::vector<std::string> overrides;
  bool check_config = false;
  app.add_option("--config", config_file, "YAML configuration (default: the thesis numbers)");
  app.add_option("--set", overrides, "override KEY=VALUE (repeatable)");
  app.add_option("--out", out_dir, "folder for errors.csv, features.csv and scene.json");
  app.add_option("--plots", plots_dir, "folder for PNG figures (needs python3-matplotlib)");
  app.add_flag("--check-config", check_config, "print the effective configuration and exit");
  CLI11_PARSE(app, argc, argv);
  try {
    auto doc = harvest::rt::load_config(config_file, overrides);
    const auto root = doc.root();
    const auto scenario = ctl::ThesisScenario::from_config(root.child("scenario"));
    const auto params = ctl::TbzParams::from_config(root.child("controller"), ctl::TbzParams::thesis_simulation());
    const auto sim = root.child("simulation");
    ctl::SimOptions opt;
    opt.duration = sim.get<double>("duration_s", 10.0, {1e-3, 1e4});
    opt.dt = sim.get<double>("dt_s", 1e-3, {1e-6, 1.0});
    opt.record_period = sim.get<double>("record_period_s", 0.01, {1e-6, 10.0});
    opt.use_vanishing_points = sim.get<bool>("use_vanishing_points", true);
    doc.check_unused();
    if (check_config) {
      std::cout << doc.emit() << '\n';
      return 0;
    }
    const auto scene = ctl::fit_scene(scenario);
    std::cerr << "scene fit: " << scene.report_json() << '\n';
    const auto result = ctl::simulate(scenario, scene, params, opt);
    if (result.summary.failed_steps > 0)
      std::cerr << "warning: controller refused " << result.summary.failed_steps << " steps\n";
    if (out_dir.empty()) out_dir = plots_dir;
    if (!out_dir.empty()) {
      std::filesystem::create_directories(out_dir);
      ctl::write_errors_csv(out_dir + "/errors.csv", result);
      ctl::write_features_csv(out_dir + "/features.csv", result);
      std::ofstream(out_dir + "/scene.json") << scene.report_json() << '\n';
    }
    if (!plots_dir.empty()) {
      std::filesystem::create_directories(plots_dir);
      // The Debian interpreter has python3-matplotlib; HARVEST_PYTHON overrides it.
      const char* py = std::getenv("HARVEST_PYTHON");
      const std::string cmd = std::string(py ? py : "/usr/bin/python3") +
                              " '" HARVEST_TOOLS_DIR "/plot_tbz.py' --csv '" + out_dir + "' --out '" + plots_dir + "'";
      if (std::system(cmd.c_str()) != 0) {
        std::cerr << "error: plotting failed: " << cmd << '\n';
        std::cout << result.summary.json() << std::endl;
        return 1;
      }
    }
    std::cout << result.summary.json() << std::endl;
    return 0;
  } catch (const harvest::config::Error& e) {
    std::cerr << "configuration error: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
}
