#include "features/nodes.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "runtime/channels.hpp"

namespace harvest::features {

TrackerParams tracker_params_from_yaml(const config::Node& n) {
  TrackerParams p;
  const config::Node c = n.child("corners");
  p.corners.window = c.get("window", p.corners.window, {3, 31});
  if (p.corners.window % 2 == 0) c.fail("window", "an odd number of pixels");
  p.corners.min_eigenvalue = c.get("min_eigenvalue", p.corners.min_eigenvalue, {0.0, 1e9});
  p.corners.quality_level = c.get("quality_level", p.corners.quality_level, {0.0, 1.0});
  p.corners.min_distance = c.get("min_distance_px", p.corners.min_distance, {0.0, 1000.0});
  p.corners.border = c.get("border_px", p.corners.border, {0, 1000});
  const config::Node k = n.child("klt");
  p.lk.window = k.get("window", p.lk.window, {3, 63});
  if (p.lk.window % 2 == 0) k.fail("window", "an odd number of pixels");
  p.lk.levels = k.get("levels", p.lk.levels, {1, 6});
  p.lk.max_iterations = k.get("max_iterations", p.lk.max_iterations, {1, 1000});
  p.lk.epsilon_px = k.get("epsilon_px", p.lk.epsilon_px, {1e-6, 10.0});
  p.lk.min_eigenvalue = k.get("min_eigenvalue", p.lk.min_eigenvalue, {0.0, 1e9});
  p.max_error = k.get("max_error", p.max_error, {0.0, 255.0});
  p.max_features = n.get("max_features", p.max_features, {1, 10000});
  p.min_features = n.get("min_features", p.min_features, {0, p.max_features});
  p.corners.max_corners = p.max_features;
  return p;
}

MatcherParams matcher_params_from_yaml(const config::Node& n) {
  MatcherParams p;
  p.orb_features = n.get("orb_features", p.orb_features, {10, 100000});
  p.orb_levels = n.get("orb_levels", p.orb_levels, {1, 16});
  p.orb_scale = n.get("orb_scale", p.orb_scale, {1.01, 2.0});
  p.fast_threshold = n.get("fast_threshold", p.fast_threshold, {1, 255});
  p.ratio = n.get("ratio", p.ratio, {0.1, 1.0});
  p.mutual = n.get("mutual", p.mutual);
  p.ransac_threshold_px = n.get("ransac_threshold_px", p.ransac_threshold_px, {0.01, 100.0});
  p.ransac_iterations = n.get("ransac_iterations", p.ransac_iterations, {1, 1000000});
  p.seed = static_cast<uint64_t>(n.get<int64_t>("seed", static_cast<int64_t>(p.seed), {0, INT64_MAX}));
  p.min_inliers = n.get("min_inliers", p.min_inliers, {4, 100000});
  p.refine = n.get("refine", p.refine);
  p.refine_lk.window = n.get("refine_window", p.refine_lk.window, {3, 63});
  if (p.refine_lk.window % 2 == 0) n.fail("refine_window", "an odd number of pixels");
  p.refine_max_shift_px = n.get("refine_max_shift_px", p.refine_max_shift_px, {0.01, 100.0});
  p.track = n.get("track", p.track);
  p.track_corners = n.get("track_corners", p.track_corners, {8, 10000});
  p.track_levels = n.get("track_levels", p.track_levels, {1, 6});
  p.track_min_fraction = n.get("track_min_fraction", p.track_min_fraction, {0.0, 1.0});
  return p;
}

FeatureTrackerConfig FeatureTrackerConfig::from_yaml(const config::Node& n) {
  FeatureTrackerConfig c;
  c.camera = n.get<std::string>("camera", c.camera);
  c.image_channel = n.get<std::string>("image_channel", channels::kCameraHand);
  c.desired_channel = n.get<std::string>("desired_channel", channels::kCameraFixedZoom);
  c.fruit_channel = n.get<std::string>("fruit_channel", channels::kFruitHand);
  c.tracks_channel = n.get<std::string>("tracks_channel", channels::kFeaturesHand);
  c.matches_channel = n.get<std::string>("matches_channel", channels::kFeatureMatches);
  c.region = n.choice("region", c.region, {"image", "fruit"});
  c.fruit_margin = n.get("fruit_margin", c.fruit_margin, {0.0, 10.0});
  c.fruit_max_age_s = n.get("fruit_max_age_s", c.fruit_max_age_s, {0.0, 3600.0});
  c.matching = n.get("matching", c.matching);
  c.max_frame_age_s = n.get("max_frame_age_s", c.max_frame_age_s, {0.0, 3600.0});
  c.tracker = tracker_params_from_yaml(n.child("tracker"));
  c.matcher = matcher_params_from_yaml(n.child("matcher"));
  return c;
}

FeatureTrackerNode::FeatureTrackerNode(FeatureTrackerConfig config)
    : rt::Node("feature-tracker-" + config.camera),
      config_(std::move(config)),
      tracker_(config_.tracker),
      matcher_(config_.matcher) {}

void FeatureTrackerNode::on_attach() {
  advertise(config_.tracks_channel);
  if (config_.matching) {
    advertise(config_.matches_channel);
    subscribe<image_t>(config_.desired_channel, [this](const image_t& m) { on_desired(m); });
  }
  if (config_.region == "fruit")
    subscribe<fruit_detections_t>(config_.fruit_channel, [this](const fruit_detections_t& m) { on_fruit(m); });
  subscribe<image_t>(config_.image_channel, [this](const image_t& m) { on_image(m); });
  set_health(rt::Health::kOk, "waiting for images on " + config_.image_channel);
}

void FeatureTrackerNode::on_fruit(const fruit_detections_t& fruit) {
  fruit_ = fruit;
  fruit_received_ = now();
}

cv::Rect FeatureTrackerNode::region_for(const image_t& image, const cv::Size& size) const {
  if (config_.region != "fruit") return {};
  if (!fruit_ || fruit_->status != fruit_detections_t::STATUS_OK || fruit_->selected_index < 0 ||
      fruit_->selected_index >= fruit_->num_fruits ||
      now() - fruit_received_ > static_cast<rt::Micros>(config_.fruit_max_age_s * 1e6))
    return {};  // no fruit: nowhere (the caller knows the mode)
  const fruit_t& f = fruit_->fruits[static_cast<std::size_t>(fruit_->selected_index)];
  // Sensor pixels -> image pixels.
  const cv::Rect2d roi = camera::image_roi(image);
  const double sx = size.width / roi.width, sy = size.height / roi.height;
  const double mx = config_.fruit_margin * f.bbox_px[2], my = config_.fruit_margin * f.bbox_px[3];
  const cv::Rect2d box((f.bbox_px[0] - mx - roi.x) * sx, (f.bbox_px[1] - my - roi.y) * sy, (f.bbox_px[2] + 2 * mx) * sx,
                       (f.bbox_px[3] + 2 * my) * sy);
  cv::Rect r(cvFloor(box.x), cvFloor(box.y), cvCeil(box.width), cvCeil(box.height));
  r &= cv::Rect(0, 0, size.width, size.height);
  return r;
}

namespace {
cv::Mat1b to_gray(const cv::Mat3b& bgr) {
  cv::Mat1b g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}
}  // namespace

void FeatureTrackerNode::on_desired(const image_t& image) {
  const auto d = camera::decode_image(image);
  if (!d.ok()) {
    count("bad_desired_images");
    set_health(rt::Health::kDegraded, "desired image: " + d.error);
    return;
  }
  matcher_.set_desired(to_gray(d.bgr));
  // Its pixels go out in its sensor's pixels, as the current image's do: a
  // zoomed image binned like the camera-in-hand's compares with it directly.
  const cv::Rect2d roi = camera::image_roi(image);
  desired_roi_ = {roi.x, roi.y, roi.width / d.bgr.cols, roi.height / d.bgr.rows};
  count("desired_images");
}

void FeatureTrackerNode::on_image(const image_t& image) {
  if (config_.max_frame_age_s > 0.0 && rt::to_seconds(now() - image.header.utime) > config_.max_frame_age_s) {
    count("frames_skipped_late");
    return;
  }
  const auto d = camera::decode_image(image);
  if (!d.ok()) {
    count("bad_images");
    set_health(rt::Health::kDegraded, d.error);
    return;
  }
  const cv::Mat1b gray = to_gray(d.bgr);
  const cv::Rect2d roi = camera::image_roi(image);
  const double sx = roi.width / gray.cols, sy = roi.height / gray.rows;
  const bool fruit_mode = config_.region == "fruit";
  cv::Rect region = region_for(image, gray.size());

  TrackerUpdate u;
  if (fruit_mode && region.area() == 0) {
    // No fruit to look at: nothing may be tracked.
    u.lost = static_cast<int>(tracker_.tracks().size());
    tracker_.reset();
  } else {
    u = tracker_.update(gray, region);
  }

  feature_tracks_t tracks{};
  tracks.header.utime = image.header.utime;
  tracks.header.source_seq = image.header.seq;
  tracks.header.frame_id = image.header.frame_id;
  tracks.camera = config_.camera;
  for (const auto& t : tracker_.tracks()) {
    feature_t f{};
    f.id = t.id;
    f.u_px = static_cast<float>(roi.x + t.pt.x * sx);
    f.v_px = static_cast<float>(roi.y + t.pt.y * sy);
    f.quality = t.quality;
    f.error = t.error;
    f.age = t.age;
    tracks.features.push_back(f);
  }
  tracks.num_features = static_cast<int32_t>(tracks.features.size());
  tracks.num_lost = u.lost;
  tracks.num_new = u.added;
  publish(config_.tracks_channel, tracks);
  count("frames");
  count("features_lost", u.lost);

  if (!config_.matching) {
    set_health(rt::Health::kOk, std::to_string(tracks.num_features) + " features");
    return;
  }
  const MatchResult m = matcher_.match(gray, fruit_mode ? region : cv::Rect());
  feature_matches_t out{};
  out.header = tracks.header;
  out.status = static_cast<int8_t>(m.status);
  out.status_text = m.text;
  for (std::size_t i = 0; i < m.desired.size(); ++i) {
    out.desired_u_px.push_back(static_cast<float>(desired_roi_[0] + m.desired[i].x * desired_roi_[2]));
    out.desired_v_px.push_back(static_cast<float>(desired_roi_[1] + m.desired[i].y * desired_roi_[3]));
    out.current_u_px.push_back(static_cast<float>(roi.x + m.current[i].x * sx));
    out.current_v_px.push_back(static_cast<float>(roi.y + m.current[i].y * sy));
  }
  out.num_matches = static_cast<int32_t>(m.desired.size());
  out.num_inliers = m.num_inliers;
  publish(config_.matches_channel, out);
  if (m.ok()) {
    count("matched_frames");
    if (m.tracked) count("tracked_frames");
    set_health(rt::Health::kOk, std::to_string(tracks.num_features) + " features, " + m.text);
  } else {
    count(m.status == MatchStatus::kNoDesired ? "frames_without_desired" : "frames_too_few_matches");
    set_health(rt::Health::kDegraded, std::string("matching: ") + m.text);
  }
}

rt::NodeList make_feature_tracker(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<FeatureTrackerNode>(FeatureTrackerConfig::from_yaml(cfg)));
  return nodes;
}

}  // namespace harvest::features
