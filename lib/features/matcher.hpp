// Correspondences between the desired image (the zoomed fixed-camera image,
// teach by zooming, thesis chapter 5) and the current camera-in-hand image.
//
// 1. ORB keypoints and binary descriptors in both images (OpenCV
//    features2d; the desired image's over a scale pyramid, once, the
//    current frame's at one scale by default), nearest-neighbour matching
//    with Lowe's ratio test and a mutual-best check.
// 2. Geometric verification: our RANSAC homography (lib/geometry) from the
//    desired to the current image; the target is planar (a sticker, a
//    patch of fruit), so consistent matches obey one homography.
// 3. Optional sub-pixel refinement: the current image is warped into the
//    desired image with the homography (only tiles around the inliers), the
//    desired inliers are tracked into it with our Lucas-Kanade, mapped
//    back, and the homography is refitted.
// 4. Frame to frame (`track`): once a frame is verified, the next one is not
//    detected afresh. The desired image's Shi-Tomasi corners are followed
//    into it instead: the new image is warped into the desired one with the
//    last homography, the corners are tracked into the warp with pyramidal
//    Lucas-Kanade (templates always from the desired image, so nothing
//    drifts), mapped back and verified with RANSAC. When too few of them
//    verify, the same frame is detected afresh (steps 1-3).
// Fewer than four consistent matches is an explicit status (kTooFew): it is
// what the thesis found on natural, untextured fruit.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <optional>
#include <string>
#include <vector>

#include "features/lucas_kanade.hpp"

namespace harvest::features {

struct MatcherParams {
  // The desired image's ORB keypoints (found once, when it arrives).
  int orb_features = 1000;  // keypoints
  int orb_levels = 6;       // ORB scale pyramid: matches a current frame 1.2^5 = 2.5 times smaller
  double orb_scale = 1.2;
  int fast_threshold = 10;
  // The current frame's (every frame detected afresh: the cost that
  // counts). The desired image is a zoom of the target, so the current
  // frame sees it at most a little larger than the desired image does and
  // usually smaller: the desired image's pyramid covers the scale range,
  // the current frame needs few levels of its own.
  int current_features = 300;
  int current_levels = 1;
  int current_fast_threshold = 20;
  double ratio = 0.8;  // Lowe ratio test
  bool mutual = true;  // keep only mutual best matches
  double ransac_threshold_px = 3.0;
  int ransac_iterations = 2000;
  uint64_t seed = 1;  // RANSAC seed (deterministic replay)
  // Below: kTooFew. Four is the minimum for a homography, but any four
  // matches fit one exactly, so four verify nothing: 8 by default.
  int min_inliers = 8;
  bool refine = true;  // sub-pixel refinement with Lucas-Kanade
  LkParams refine_lk{15, 1, 20, 0.01, 1e-3};
  double refine_max_shift_px = 2.0;  // a refined point moving more than this is dropped
  bool track = true;                 // follow the desired corners frame to frame after a verified frame
  int track_corners = 200;           // Shi-Tomasi corners of the desired image (its region) that are followed
  int track_levels = 3;              // pyramid levels for the motion between two frames
  double track_min_fraction = 0.5;   // fewer of the corners verified: detect afresh
};

// The selected fruit's face in the current image: a disc inside its
// outline. Features on the outline belong to the silhouette (peel against
// whatever is behind it), which slides over the fruit with every change of
// viewpoint, and features beside it are leaves: neither is the target's
// texture. On natural fruit they are all a matcher finds (docs/teach-by-zooming.md).
struct Disc {
  cv::Point2f centre;
  float radius = 0;  // <= 0: no disc, everywhere
  bool empty() const { return !(radius > 0); }
  bool contains(const cv::Point2f& p) const {
    const float dx = p.x - centre.x, dy = p.y - centre.y;
    return dx * dx + dy * dy <= radius * radius;
  }
};

enum class MatchStatus : int8_t { kOk = 0, kTooFew = 1, kNoDesired = 2, kDegenerate = 3 };
const char* to_string(MatchStatus s);

struct MatchResult {
  MatchStatus status = MatchStatus::kNoDesired;
  std::string text;
  // The first num_inliers pairs passed geometric verification; the rest are
  // descriptor matches it rejected (kept for diagnosis).
  std::vector<cv::Point2f> desired, current;
  int num_inliers = 0;
  int num_candidates = 0;              // descriptor matches before verification
  int num_off_face = 0;                // of those, outside the face (never verified)
  cv::Matx33d G = cv::Matx33d::eye();  // desired -> current, valid when status is kOk
  double rms_px = 0;
  bool tracked = false;  // from the previous frame's homography (step 4), not detected afresh
  bool ok() const { return status == MatchStatus::kOk; }
};

namespace detail {
// Brute-force Hamming matching of 32-byte descriptors (ORB): for every
// desired row the best and second-best current row, for every current row
// the best desired row; ties keep the lower index. `simd`: the AVX2 or the
// AVX-512 VPOPCNTDQ build where the CPU has it, else the portable one (all
// give the same result: exposed for that test).
struct Nearest {
  std::vector<int> best, second_dist, best_dist;  // per desired row
  std::vector<int> back;                          // per current row: best desired row
};
void hamming_nearest(bool simd, const uint8_t* desired, int nd, const uint8_t* current, int nc, Nearest& out);
}  // namespace detail

class DesiredImageMatcher {
 public:
  explicit DesiredImageMatcher(MatcherParams params);
  // The desired image; `region` (empty = whole image) limits its keypoints
  // and corners. Starts afresh: the next match is detected.
  void set_desired(const cv::Mat1b& gray, const cv::Rect& region = {});
  bool has_desired() const { return !desired_.empty(); }
  int desired_keypoints() const { return static_cast<int>(desired_kp_.size()); }
  int desired_corners() const { return static_cast<int>(corners_.size()); }
  // Matches one frame of a sequence. `region` (empty = whole image) limits
  // where current keypoints may be; `face` (empty = anywhere), where the
  // current points of matches may be: a match outside it is not verified
  // (it is reported among the rejected ones). The result depends on the
  // frames before (step 4): the same sequence gives the same results.
  MatchResult match(const cv::Mat1b& current, const cv::Rect& region = {}, const Disc& face = {});
  // Forget the previous frame: the next match is detected afresh.
  void reset_tracking() { last_G_.reset(); }
  const MatcherParams& params() const { return params_; }

 private:
  MatchResult detect(const cv::Mat1b& current, const cv::Rect& region, const Disc& face) const;
  MatchResult track(const cv::Mat1b& current, const cv::Rect& region, const Disc& face, const cv::Matx33d& G) const;

  MatcherParams params_;
  cv::Ptr<cv::ORB> orb_, orb_current_;
  cv::Mat1b desired_;
  Pyramid desired_pyr_;
  std::vector<cv::KeyPoint> desired_kp_;
  cv::Mat desired_desc_;
  // Step 4: the followed corners, the box of the desired image around them
  // (with room for the tracking windows) and its pyramid.
  std::vector<cv::Point2f> corners_;
  cv::Rect box_;
  Pyramid box_pyr_;
  std::optional<cv::Matx33d> last_G_;  // desired -> current of the last verified frame
};

}  // namespace harvest::features
