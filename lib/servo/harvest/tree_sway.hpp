// Whether the tree sways, from the fixed camera. It stands still, so a
// fruit's centroid in its images moves only with the fruit, the detector's
// noise and the arm passing in front of it. The hand camera, moving, cannot
// tell a still fruit from a swaying one as well: seen while the arm moves, a
// still fruit's positions spread by the depth error's sideways share, and on
// still trees the approach held one fruit in two for its "sway" (0.8-2.5 s
// each). Wind moves every fruit, the arm a few: the fruit at a low quantile
// of the spreads stands for the tree.
#pragma once
#include <deque>
#include <map>

#include "harvest/targets_t.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class TreeSwayGauge {
 public:
  enum class Verdict { kUnknown, kStill, kSwaying };
  struct Reading {
    Verdict verdict = Verdict::kUnknown;
    double rms = 0.0;  // [m] the spread at tree_quantile among the fruit counted (0 when unknown)
    int fruit = 0;     // fruit counted: views spanning tree_min_span within tree_window
  };

  explicit TreeSwayGauge(ServoConfig::Sway params) : p_(params) {}

  // A fixed-camera TARGETS (other cameras are ignored). Views older than
  // tree_window before this message are dropped; the reading is recomputed.
  void add(const targets_t& fixed);
  const Reading& reading() const { return reading_; }
  // tree_window 0: never a verdict.
  bool enabled() const { return p_.tree_window > 0.0; }
  // Fruit ids with views kept (at most kMaxFruit).
  int tracked() const { return static_cast<int>(views_.size()); }

  // Bounds on the work a flood of TARGETS can cause (a tree has tens of fruit in view; the reading changes
  // slowly): new ids beyond kMaxFruit are not watched, and the reading is recomputed at most every kEvery_s of
  // image time.
  static constexpr int kMaxFruit = 256;
  static constexpr double kEvery_s = 0.1;

 private:
  struct View {
    double t;              // [s] image time
    double u, v;           // [px] centroid
    double metres_per_px;  // the fruit's assumed diameter over its apparent one
  };
  void update(double now);

  ServoConfig::Sway p_;
  std::map<int32_t, std::deque<View>> views_;  // by fixed-camera fruit id
  Reading reading_;
  double updated_ = -1e300;  // [s] image time of the last recomputation
};

}  // namespace harvest::servo
