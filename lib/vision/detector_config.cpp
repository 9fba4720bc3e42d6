#include "vision/detector_config.hpp"

#include <string>

#include "config/config.hpp"
#include "config/schema.hpp"

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
  namespace k = detector_keys;
  const std::string mode = n.get(k::mode);
  DetectorConfig c = mode == "thesis" ? thesis() : canopy();
  if (mode == "learned") {
    c.mode = Mode::learned;
    c.learned.model = n.get(learned_keys::model);
    c.learned.input_width = n.get(learned_keys::input_width);
    c.learned.threshold = n.get(learned_keys::threshold);
    c.learned.merge_within = n.get(learned_keys::merge_within);
    c.learned.score_visible = n.get(learned_keys::score_visible);
    c.learned.rescale_above = n.get(learned_keys::rescale_above);
    c.learned.finer_above = n.get(learned_keys::finer_above);
    c.learned.finer_below = n.get(learned_keys::finer_below);
    c.learned.finer_threshold = n.get(learned_keys::finer_threshold);
    // Load it now: a bad file is an error at start (and for --check-config), not at the first frame.
    try {
      LearnedDetector check(c.learned);
    } catch (const std::exception& e) {
      n.fail("model", std::string("a loadable fruit network (") + e.what() + ")");
    }
  }
  auto& t = c.thresholds;
  t.cr_min = n.get(threshold_keys::cr_min);
  t.cr_max = n.get(threshold_keys::cr_max);
  t.cg_min = n.get(threshold_keys::cg_min);
  t.cg_max = n.get(threshold_keys::cg_max);
  t.cb_min = n.get(threshold_keys::cb_min);
  t.cb_max = n.get(threshold_keys::cb_max);
  if (t.cr_min > t.cr_max) n.fail("cr_max", "a value >= cr_min");
  if (t.cg_min > t.cg_max) n.fail("cg_max", "a value >= cg_min");
  if (t.cb_min > t.cb_max) n.fail("cb_max", "a value >= cb_min");
  c.min_area_px = n.get(k::min_area_px);
  c.fruit_diameter_m = n.get(k::fruit_diameter_m);
  c.kr = n.get(k::kr);
  c.kd_per_m = n.get(k::kd_per_m);
  // The switches' defaults are the mode's preset.
  c.open_radius_px = n.get(k::open_radius_px, c.open_radius_px);
  c.close_radius_px = n.get(k::close_radius_px, c.close_radius_px);
  c.fill_holes = n.get(k::fill_holes, c.fill_holes);
  c.split_touching = n.get(k::split_touching, c.split_touching);
  c.split_min_radius_px = n.get(k::split_min_radius_px);
  c.split_min_peak_ratio = n.get(k::split_min_peak_ratio);
  c.peel_to_circle = n.get(k::peel_to_circle, c.peel_to_circle);
  c.merge_fragments = n.get(k::merge_fragments, c.merge_fragments);
  c.merge_max_gap_ratio = n.get(k::merge_max_gap_ratio);
  c.sky_cb_min = n.get(k::sky_cb_min);
  c.reject_shapes = n.get(k::reject_shapes, c.reject_shapes);
  c.min_roundness = n.get(k::min_roundness);
  c.min_solidity = n.get(k::min_solidity);
  c.min_solidity_fitted = n.get(k::min_solidity_fitted);
  c.max_aspect_ratio = n.get(k::max_aspect_ratio);
  c.circle_fit = n.get(k::circle_fit, c.circle_fit);
  c.min_visible_fraction = n.get(k::min_visible_fraction);
  return c;
}

config::Section DetectorConfig::schema(const std::string& path, const std::string& where) {
  namespace k = detector_keys;
  namespace t = threshold_keys;
  namespace l = learned_keys;
  return config::section(
      path, where, k::mode, l::model, l::input_width, l::threshold, l::merge_within, l::score_visible, l::rescale_above,
      l::finer_above, l::finer_below, l::finer_threshold, t::cr_min, t::cr_max, t::cg_min, t::cg_max, t::cb_min,
      t::cb_max, k::min_area_px, k::fruit_diameter_m, k::kr, k::kd_per_m, k::open_radius_px, k::close_radius_px,
      k::fill_holes, k::split_touching, k::split_min_radius_px, k::split_min_peak_ratio, k::peel_to_circle,
      k::merge_fragments, k::merge_max_gap_ratio, k::sky_cb_min, k::reject_shapes, k::min_roundness, k::min_solidity,
      k::min_solidity_fitted, k::max_aspect_ratio, k::circle_fit, k::min_visible_fraction);
}

}  // namespace harvest::vision
