#include "vision/detector_config.hpp"

#include <string>

#include "config/config.hpp"

namespace harvest::vision {

DetectorConfig DetectorConfig::thesis() { return {}; }

DetectorConfig DetectorConfig::learned_mode(const std::filesystem::path& model) {
  DetectorConfig c;
  c.mode = Mode::learned;
  c.learned.model = model;
  return c;
}

DetectorConfig DetectorConfig::canopy() {
  DetectorConfig c;
  c.mode = Mode::canopy;
  c.open_radius_px = 1;
  c.close_radius_px = 2;
  c.fill_holes = true;
  c.split_touching = true;
  c.peel_to_circle = true;
  c.merge_fragments = true;
  c.reject_shapes = true;
  c.circle_fit = true;
  return c;
}

DetectorConfig DetectorConfig::from_yaml(const config::Node& n) {
  const std::string mode = n.choice("mode", "canopy", {"thesis", "canopy", "learned"});
  DetectorConfig c = mode == "thesis" ? thesis() : canopy();
  if (mode == "learned") {
    c.mode = Mode::learned;
    c.learned.model = n.file_path("model", "config/vision/models/fruit_net.onnx");
    c.learned.input_width = n.get("input_width", c.learned.input_width, {16, 4096});
    c.learned.threshold = n.get("threshold", c.learned.threshold, {0.01, 1.0});
    // Load it now: a bad file is an error at start (and for --check-config), not at the first frame.
    try {
      LearnedDetector check(c.learned);
    } catch (const std::exception& e) {
      n.fail("model", std::string("a loadable fruit network (") + e.what() + ")");
    }
  }
  const config::Range<double> any{-1000, 1000};
  auto& t = c.thresholds;
  t.cr_min = n.get("cr_min", t.cr_min, any);
  t.cr_max = n.get("cr_max", t.cr_max, any);
  t.cg_min = n.get("cg_min", t.cg_min, any);
  t.cg_max = n.get("cg_max", t.cg_max, any);
  t.cb_min = n.get("cb_min", t.cb_min, any);
  t.cb_max = n.get("cb_max", t.cb_max, any);
  if (t.cr_min > t.cr_max) n.fail("cr_max", "a value >= cr_min");
  if (t.cg_min > t.cg_max) n.fail("cg_max", "a value >= cg_min");
  if (t.cb_min > t.cb_max) n.fail("cb_max", "a value >= cb_min");
  c.min_area_px = n.get<int64_t>("min_area_px", c.min_area_px, {0, 100'000'000});
  c.fruit_diameter_m = n.get("fruit_diameter_m", c.fruit_diameter_m, {0.01, 0.5});
  c.kr = n.get("kr", c.kr, {0.0, 1e6});
  c.kd_per_m = n.get("kd_per_m", c.kd_per_m, {0.0, 1e6});
  c.open_radius_px = n.get("open_radius_px", c.open_radius_px, {0, 50});
  c.close_radius_px = n.get("close_radius_px", c.close_radius_px, {0, 50});
  c.fill_holes = n.get("fill_holes", c.fill_holes);
  c.split_touching = n.get("split_touching", c.split_touching);
  c.split_min_radius_px = n.get("split_min_radius_px", c.split_min_radius_px, {0.5, 1000.0});
  c.split_min_peak_ratio = n.get("split_min_peak_ratio", c.split_min_peak_ratio, {0.0, 1.0});
  c.peel_to_circle = n.get("peel_to_circle", c.peel_to_circle);
  c.merge_fragments = n.get("merge_fragments", c.merge_fragments);
  c.merge_max_gap_ratio = n.get("merge_max_gap_ratio", c.merge_max_gap_ratio, {0.0, 10.0});
  c.sky_cb_min = n.get("sky_cb_min", c.sky_cb_min, {-1000.0, 1000.0});
  c.reject_shapes = n.get("reject_shapes", c.reject_shapes);
  c.min_roundness = n.get("min_roundness", c.min_roundness, {0.0, 1.0});
  c.min_solidity = n.get("min_solidity", c.min_solidity, {0.0, 1.0});
  c.max_aspect_ratio = n.get("max_aspect_ratio", c.max_aspect_ratio, {1.0, 100.0});
  c.circle_fit = n.get("circle_fit", c.circle_fit);
  c.min_visible_fraction = n.get("min_visible_fraction", c.min_visible_fraction, {0.0, 1.0});
  return c;
}

}  // namespace harvest::vision
