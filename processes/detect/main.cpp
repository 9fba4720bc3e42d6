// harvest-detect [--config FILE] [--overlay DIR] IMAGE...: offline fruit detection, JSON lines on stdout.
// harvest-detect --evaluate boxes.csv [--images-dir DIR] [--fold-models CSV]: precision and recall against
// annotated boxes (with --fold-models each image scored by a learned model that did not train on it).
#include <CLI/CLI.hpp>
#include <iostream>

#include "vision/detect_tool.hpp"

int main(int argc, char** argv) {
  harvest::vision::DetectToolOptions o;
  std::string overlay, evaluate, images_dir;
  CLI::App app("Detect fruit in image files; prints one JSON object per image", "harvest-detect");
  app.add_option("--config,-c", o.config_file, "detector configuration (as for harvest-fruit-detector)");
  app.add_option("--set", o.overrides, "override a configuration value, KEY.PATH=VALUE (repeatable)");
  app.add_option("--overlay", overlay, "write each image with its detections drawn to this folder");
  auto* eval = app.add_option("--evaluate", evaluate,
                              "score against annotated boxes, a CSV image,img_w,img_h,x1,y1,x2,y2[,visible] "
                              "(prints precision and recall; a fruit under half visible is neither found nor missed)");
  app.add_option("--images-dir", images_dir, "folder of the CSV's images (default: <CSV folder>/images)")->needs(eval);
  std::string fold_models;
  app.add_option("--fold-models", fold_models,
                 "cross-validation: CSV image,model naming per image the learned model that did not train on it")
      ->needs(eval);
  auto* images = app.add_option("images", o.images, "image files");
  images->excludes(eval);
  try {
    app.parse(argc, argv);
    if (evaluate.empty() && o.images.empty()) throw CLI::RequiredError("images (or --evaluate)");
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  o.overlay_dir = overlay;
  o.evaluate_csv = evaluate;
  o.images_dir = images_dir;
  o.fold_models = fold_models;
  return harvest::vision::run_detect_tool(o, std::cout, std::cerr);
}
