#include "features/nodes.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "config/schema.hpp"
#include "runtime/channels.hpp"

namespace harvest::features {

namespace {
// The keys of config/features/feature_tracker.yaml (docs/feature-tracker.md).
// Their defaults are the parameter structs' (TrackerParams{}, MatcherParams{},
// FeatureTrackerConfig{}); a test loads an empty file and compares.
using config::Key;
namespace kc {  // tracker.corners
constexpr Key<int> window{"window", 7, {3, 31}, "px", "Shi-Tomasi window side, odd (thesis 7 x 7)"};
constexpr Key<double> min_eigenvalue{"min_eigenvalue", 78.0, {0.0, 1e9}, "",
                                     "absolute threshold on the smaller eigenvalue (eq. 2-3)"};
constexpr Key<double> quality_level{"quality_level", 0.0, {0.0, 1.0}, "",
                                    "also reject below this x the strongest eigenvalue (0: off)"};
constexpr Key<double> min_distance_px{"min_distance_px", 10.0, {0.0, 1000.0}, "px",
                                      "minimum spacing between accepted corners"};
constexpr Key<int> border_px{"border_px", 10, {0, 1000}, "px", "pixels along the image edge not searched"};
}  // namespace kc
namespace kk {  // tracker.klt
constexpr Key<int> window{"window", 7, {3, 63}, "px", "KLT window side, odd (thesis 7)"};
constexpr Key<int> levels{"levels", 3, {1, 6}, "", "pyramid levels including the image (thesis 3)"};
constexpr Key<int> max_iterations{"max_iterations", 30, {1, 1000}, "", "per level"};
constexpr Key<double> epsilon_px{"epsilon_px", 0.1, {1e-6, 10.0}, "px",
                                 "stop when a Newton step is shorter than this (thesis track_tol)"};
constexpr Key<double> min_eigenvalue{"min_eigenvalue", 1e-2, {0.0, 1e9}, "",
                                     "a window whose gradient matrix is weaker is lost"};
constexpr Key<double> max_error{"max_error", 40.0, {0.0, 255.0}, "",
                                "drop a feature whose KLT residual exceeds this (grey levels)"};
}  // namespace kk
namespace kt {  // tracker
constexpr Key<int> max_features{"max_features", 100, {1, 10000}, "", "replenish up to this many"};
constexpr Key<int> min_features{"min_features", 30, {0, 10000}, "",
                                "replenish when fewer are tracked (at most max_features)"};
}  // namespace kt
namespace km {  // matcher
constexpr Key<int> orb_features{"orb_features", 1000, {10, 100000}, "", "ORB keypoints of the desired image"};
constexpr Key<int> orb_levels{"orb_levels", 6, {1, 16}, "",
                              "its ORB scale pyramid levels (the current frame may see the target this much smaller)"};
constexpr Key<double> orb_scale{"orb_scale", 1.2, {1.01, 2.0}, "", "ORB pyramid scale step"};
constexpr Key<int> fast_threshold{"fast_threshold", 10, {1, 255}, "", "its FAST corner threshold"};
constexpr Key<int> current_features{"current_features", 300, {10, 100000}, "",
                                    "ORB keypoints of a current frame detected afresh"};
constexpr Key<int> current_levels{"current_levels", 1, {1, 16}, "",
                                  "its ORB scale pyramid levels (more: matches when it sees the target larger)"};
constexpr Key<int> current_fast_threshold{"current_fast_threshold", 20, {1, 255}, "", "its FAST corner threshold"};
constexpr Key<double> ratio{"ratio", 0.8, {0.1, 1.0}, "", "Lowe ratio test"};
constexpr Key<bool> mutual{"mutual", true, {}, "", "keep only mutual best matches"};
constexpr Key<double> ransac_threshold_px{"ransac_threshold_px", 3.0, {0.01, 100.0}, "px",
                                          "homography RANSAC inlier threshold"};
constexpr Key<int> ransac_iterations{"ransac_iterations", 2000, {1, 1000000}, "", "RANSAC iterations"};
constexpr Key<int64_t> seed{"seed", 1, {0, INT64_MAX}, "", "RANSAC seed (deterministic replay)"};
constexpr Key<int> min_inliers{"min_inliers", 8, {4, 100000}, "",
                               "fewer: STATUS_TOO_FEW (any 4 pairs fit a homography: 4 verifies nothing)"};
constexpr Key<bool> refine{"refine", true, {}, "", "sub-pixel refinement with Lucas-Kanade"};
constexpr Key<int> refine_window{"refine_window", 15, {3, 63}, "px", "its window side, odd"};
constexpr Key<double> refine_max_shift_px{"refine_max_shift_px", 2.0, {0.01, 100.0}, "px",
                                          "a refined point moving more than this is dropped"};
constexpr Key<bool> track{"track", true, {}, "",
                          "follow the desired corners frame to frame after a verified frame"};
constexpr Key<int> track_corners{"track_corners", 200, {8, 10000}, "",
                                 "Shi-Tomasi corners of the desired image that are followed"};
constexpr Key<int> track_levels{"track_levels", 3, {1, 6}, "", "pyramid levels for the motion between two frames"};
constexpr Key<double> track_min_fraction{"track_min_fraction", 0.5, {0.0, 1.0}, "",
                                         "fewer of the corners verified: detect afresh"};
}  // namespace km
namespace kn {  // the node
constexpr Key<std::string> camera{"camera", "hand", {}, "", "the camera's name (node and instance)"};
constexpr Key<std::string> image_channel{"image_channel", channels::kCameraHand, {}, "", "images tracked"};
constexpr Key<std::string> desired_channel{"desired_channel", channels::kCameraFixedZoom, {}, "",
                                           "the desired (zoomed fixed-camera) image"};
constexpr Key<std::string> fruit_channel{"fruit_channel", channels::kFruitHand, {}, "",
                                         "detections defining the region (region fruit)"};
constexpr Key<std::string> tracks_channel{"tracks_channel", channels::kFeaturesHand, {}, "", "tracks out"};
constexpr Key<std::string> matches_channel{"matches_channel", channels::kFeatureMatches, {}, "", "matches out"};
constexpr config::Choice region{"region", "image", {"image", "fruit"},
                                "track in the whole image or around the selected fruit"};
constexpr Key<double> fruit_margin{"fruit_margin", 0.2, {0.0, 10.0}, "",
                                   "region fruit: margin around the box, a fraction of its size"};
constexpr Key<double> face_fraction{
    "face_fraction", 0.7, {0.0, 1.0}, "",
    "region fruit: matches count only this near the fruit's centre, a share of its radius (its face, not its outline; "
    "0: anywhere in the region)"};
constexpr Key<double> fruit_max_age_s{"fruit_max_age_s", 0.5, {0.0, 3600.0}, "s",
                                      "older detections do not define a region"};
constexpr Key<bool> matching{"matching", true, {}, "", "match against the desired image: FEATURE_MATCHES"};
constexpr Key<double> max_frame_age_s{"max_frame_age_s", 0.0, {0.0, 3600.0}, "s",
                                      "> 0: a frame older than this on arrival is skipped (frames_skipped_late), not answered late"};
}  // namespace kn
}  // namespace

TrackerParams tracker_params_from_yaml(const config::Node& n) {
  TrackerParams p;
  const config::Node c = n.child("corners");
  p.corners.window = c.get(kc::window);
  if (p.corners.window % 2 == 0) c.fail("window", "an odd number of pixels");
  p.corners.min_eigenvalue = c.get(kc::min_eigenvalue);
  p.corners.quality_level = c.get(kc::quality_level);
  p.corners.min_distance = c.get(kc::min_distance_px);
  p.corners.border = c.get(kc::border_px);
  const config::Node k = n.child("klt");
  p.lk.window = k.get(kk::window);
  if (p.lk.window % 2 == 0) k.fail("window", "an odd number of pixels");
  p.lk.levels = k.get(kk::levels);
  p.lk.max_iterations = k.get(kk::max_iterations);
  p.lk.epsilon_px = k.get(kk::epsilon_px);
  p.lk.min_eigenvalue = k.get(kk::min_eigenvalue);
  p.max_error = k.get(kk::max_error);
  p.max_features = n.get(kt::max_features);
  // At most max_features: a range known once that is read.
  p.min_features = n.get<int>(kt::min_features.name, kt::min_features.fallback, {0, p.max_features});
  p.corners.max_corners = p.max_features;
  return p;
}

MatcherParams matcher_params_from_yaml(const config::Node& n) {
  MatcherParams p;
  p.orb_features = n.get(km::orb_features);
  p.orb_levels = n.get(km::orb_levels);
  p.orb_scale = n.get(km::orb_scale);
  p.fast_threshold = n.get(km::fast_threshold);
  p.current_features = n.get(km::current_features);
  p.current_levels = n.get(km::current_levels);
  p.current_fast_threshold = n.get(km::current_fast_threshold);
  p.ratio = n.get(km::ratio);
  p.mutual = n.get(km::mutual);
  p.ransac_threshold_px = n.get(km::ransac_threshold_px);
  p.ransac_iterations = n.get(km::ransac_iterations);
  p.seed = static_cast<uint64_t>(n.get(km::seed));
  p.min_inliers = n.get(km::min_inliers);
  p.refine = n.get(km::refine);
  p.refine_lk.window = n.get(km::refine_window);
  if (p.refine_lk.window % 2 == 0) n.fail("refine_window", "an odd number of pixels");
  p.refine_max_shift_px = n.get(km::refine_max_shift_px);
  p.track = n.get(km::track);
  p.track_corners = n.get(km::track_corners);
  p.track_levels = n.get(km::track_levels);
  p.track_min_fraction = n.get(km::track_min_fraction);
  return p;
}

FeatureTrackerConfig FeatureTrackerConfig::from_yaml(const config::Node& n) {
  FeatureTrackerConfig c;
  c.camera = n.get(kn::camera);
  c.image_channel = n.get(kn::image_channel);
  c.desired_channel = n.get(kn::desired_channel);
  c.fruit_channel = n.get(kn::fruit_channel);
  c.tracks_channel = n.get(kn::tracks_channel);
  c.matches_channel = n.get(kn::matches_channel);
  c.region = n.get(kn::region);
  c.fruit_margin = n.get(kn::fruit_margin);
  c.face_fraction = n.get(kn::face_fraction);
  c.fruit_max_age_s = n.get(kn::fruit_max_age_s);
  c.matching = n.get(kn::matching);
  c.max_frame_age_s = n.get(kn::max_frame_age_s);
  c.tracker = tracker_params_from_yaml(n.child("tracker"));
  c.matcher = matcher_params_from_yaml(n.child("matcher"));
  return c;
}

std::vector<config::Section> FeatureTrackerConfig::schema() {
  const std::string where = "harvest-feature-tracker, config/features/feature_tracker.yaml (docs/feature-tracker.md).";
  return {config::section("feature_tracker", where, kn::camera, kn::image_channel, kn::desired_channel,
                          kn::fruit_channel, kn::tracks_channel, kn::matches_channel, kn::region, kn::fruit_margin,
                          kn::face_fraction, kn::fruit_max_age_s, kn::matching, kn::max_frame_age_s),
          config::section("feature_tracker.tracker", where, kt::max_features, kt::min_features),
          config::section("feature_tracker.tracker.corners", where, kc::window, kc::min_eigenvalue, kc::quality_level,
                          kc::min_distance_px, kc::border_px),
          config::section("feature_tracker.tracker.klt", where, kk::window, kk::levels, kk::max_iterations,
                          kk::epsilon_px, kk::min_eigenvalue, kk::max_error),
          config::section("feature_tracker.matcher", where, km::orb_features, km::orb_levels, km::orb_scale,
                          km::fast_threshold, km::current_features, km::current_levels,
                          km::current_fast_threshold, km::ratio, km::mutual, km::ransac_threshold_px, km::ransac_iterations,
                          km::seed, km::min_inliers, km::refine, km::refine_window, km::refine_max_shift_px, km::track,
                          km::track_corners, km::track_levels, km::track_min_fraction)};
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

cv::Rect FeatureTrackerNode::region_for(const image_t& image, const cv::Size& size, Disc* face) const {
  *face = {};
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
  if (config_.face_fraction > 0.0)
    *face = {cv::Point2f(static_cast<float>((f.u_px - roi.x) * sx), static_cast<float>((f.v_px - roi.y) * sy)),
             static_cast<float>(config_.face_fraction * 0.5 * f.diameter_px * 0.5 * (sx + sy))};
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
  Disc face;
  cv::Rect region = region_for(image, gray.size(), &face);

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
  const MatchResult m = matcher_.match(gray, fruit_mode ? region : cv::Rect(), face);
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
