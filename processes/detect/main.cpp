// harvest-detect [--config FILE] [--overlay DIR] IMAGE...: offline fruit detection, JSON lines on stdout.
#include <CLI/CLI.hpp>
#include <iostream>

#include "vision/detect_tool.hpp"

int main(int argc, char** argv) {
  harvest::vision::DetectToolOptions o;
  std::string overlay;
  CLI::App app("Detect fruit in image files; prints one JSON object per image", "harvest-detect");
  app.add_option("--config,-c", o.config_file, "detector configuration (as for harvest-fruit-detector)");
  app.add_option("--set", o.overrides, "override a configuration value, KEY.PATH=VALUE (repeatable)");
  app.add_option("--overlay", overlay, "write each image with its detections drawn to this folder");
  app.add_option("images", o.images, "image files")->required();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  o.overlay_dir = overlay;
  return harvest::vision::run_detect_tool(o, std::cout, std::cerr);
}
