// Feature tracking in one camera: Shi-Tomasi corners followed frame to frame
// by pyramidal Lucas-Kanade; lost features are dropped and new corners are
// detected to replenish them (thesis section 2.2, appendix B.2).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "features/corners.hpp"
#include "features/lucas_kanade.hpp"

namespace harvest::features {

struct TrackerParams {
  CornerParams corners;
  LkParams lk;
  int min_features = 30;    // replenish when fewer are tracked
  int max_features = 100;   // replenish up to this many
  double max_error = 40.0;  // drop a feature whose KLT residual exceeds this [grey levels]
};

struct Track {
  int id = 0;
  cv::Point2f pt;
  float quality = 0;  // min eigenvalue at detection
  float error = 0;    // KLT residual of the last step
  int age = 0;        // frames tracked (0 = detected in this frame)
};

struct TrackerUpdate {
  int lost = 0;   // dropped in this frame
  int added = 0;  // detected in this frame
};

class FeatureTracker {
 public:
  explicit FeatureTracker(TrackerParams params);
  // One frame. `region` (empty = whole image) and `mask` limit where features
  // may be; a tracked feature that leaves the region is dropped.
  TrackerUpdate update(const cv::Mat1b& gray, const cv::Rect& region = {}, const cv::Mat1b& mask = {});
  const std::vector<Track>& tracks() const { return tracks_; }
  void reset();
  const TrackerParams& params() const { return params_; }

 private:
  TrackerParams params_;
  Pyramid prev_;
  std::vector<Track> tracks_;
  int next_id_ = 0;
};

}  // namespace harvest::features
