// harvest-feature-tracker: Shi-Tomasi/KLT tracks in the camera-in-hand image
// (FEATURES_HAND) and teach-by-zooming correspondences between the zoomed
// fixed-camera image and the camera-in-hand image (FEATURE_MATCHES).
// See docs/feature-tracker.md.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "config/config.hpp"
#include "config/schema.hpp"
#include "features/matcher.hpp"
#include "features/tracker.hpp"
#include "harvest/feature_matches_t.hpp"
#include "harvest/feature_tracks_t.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"

namespace harvest::features {

struct FeatureTrackerConfig {
  std::string camera = "hand";
  std::string image_channel;    // default CAMERA_HAND
  std::string desired_channel;  // default CAMERA_FIXED_ZOOM
  std::string fruit_channel;    // default FRUIT_HAND
  std::string tracks_channel;   // default FEATURES_HAND
  std::string matches_channel;  // default FEATURE_MATCHES
  // Where features may be: "image" (everywhere) or "fruit" (the selected
  // fruit's box from fruit_channel, grown by fruit_margin on every side).
  std::string region = "image";
  double fruit_margin = 0.2;  // fraction of the box size
  // region fruit: matches verify only within this share of the fruit's
  // radius from its centre (its face; 0: anywhere in the region). The
  // outline and what is beside it match on natural fruit, the face does not
  // (docs/teach-by-zooming.md: every such match was beyond 0.84 of the radius).
  double face_fraction = 0.7;
  double fruit_max_age_s = 0.5;  // older detections do not define a region
  bool matching = true;          // publish FEATURE_MATCHES
  // > 0: a camera frame older than this on arrival (by the node's clock) is
  // skipped, not answered late: a tracker that falls behind catches up with
  // the newest frame instead of queueing (0: every frame).
  double max_frame_age_s = 0.0;  // = feature_tracker.max_frame_age_s's declared default (nodes.cpp)
  TrackerParams tracker;
  MatcherParams matcher;

  static FeatureTrackerConfig from_yaml(const config::Node& node);
  static std::vector<config::Section> schema();
};

// Reads the `tracker` / `matcher` blocks (exposed for tools and tests).
TrackerParams tracker_params_from_yaml(const config::Node& node);
MatcherParams matcher_params_from_yaml(const config::Node& node);

class FeatureTrackerNode : public rt::Node {
 public:
  explicit FeatureTrackerNode(FeatureTrackerConfig config);

 protected:
  void on_attach() override;

 private:
  void on_image(const image_t& image);
  void on_desired(const image_t& image);
  std::array<double, 4> desired_roi_{0, 0, 1, 1};  // the desired image's roi x, y and sensor pixels per pixel
  void on_fruit(const fruit_detections_t& fruit);
  // The selected fruit's box grown by fruit_margin, and its face (empty without one).
  cv::Rect region_for(const image_t& image, const cv::Size& size, Disc* face) const;

  FeatureTrackerConfig config_;
  FeatureTracker tracker_;
  DesiredImageMatcher matcher_;
  std::optional<fruit_detections_t> fruit_;
  rt::Micros fruit_received_ = 0;
};

rt::NodeList make_feature_tracker(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::features
