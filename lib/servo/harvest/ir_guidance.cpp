#include "servo/harvest/ir_guidance.hpp"

#include <algorithm>
#include <cmath>

#include "servo/geometry.hpp"

namespace harvest::servo {

namespace {
// The tool point's coordinate along its own axis: where the IR's readings (the surface, a leaf) are placed.
double along_axis(const Eigen::Isometry3d& tool) { return tool.translation().dot(tool.rotation().col(2)); }
}  // namespace

void IrGuidance::reset_attempt(const Eigen::Vector3d& tool, rt::Micros now) {
  leaf_at_.reset();
  leaf_noted_ = false;
  split_close_at_.reset();
  progress_at_ = now;
  progress_from_ = tool;
  folded_ = false;
  last_near_.reset();
  surface_.reset();
}

void IrGuidance::begin(const Eigen::Vector3d& tool, rt::Micros now) {
  attempt_ = 1;
  start_ = tool;
  reset_attempt(tool, now);
}

void IrGuidance::retry(const Eigen::Vector3d& tool, rt::Micros now) {
  ++attempt_;
  reset_attempt(tool, now);
}

void IrGuidance::on_reading(const ir_range_t& msg, rt::Micros now, bool guiding) {
  ir_ = msg;
  ir_rx_ = now;
  // A triangulating IR sensor folds back nearer than its peak: a fruit inside
  // reads far. Moving forward, a reading just above the grasp range followed
  // by one far beyond it is that fold-back (nothing on the axis jumps away),
  // even if no sample fell inside the few millimetres of the grasp range.
  if (!guiding || msg.validity != ir_range_t::VALID) return;
  if (msg.range_m <= cfg_.ir_grasp_range + cfg_.ir_fold_near) {
    last_near_ = msg.range_m;
  } else if (last_near_ && msg.range_m > *last_near_ + cfg_.ir_fold_jump) {
    folded_ = true;
  }
}

void IrGuidance::track_surface(const Eigen::Isometry3d& tool) {
  if (!ir_ || ir_rx_ == surface_rx_) return;
  surface_rx_ = ir_rx_;
  if (ir_->validity != ir_range_t::VALID) {
    surface_.reset();
    return;
  }
  const double along = along_axis(tool);
  const double at = along + ir_->range_m;
  if (surface_ && std::abs(at - surface_->at) <= cfg_.ir_surface_tolerance) {
    surface_->from = std::min(surface_->from, along);
    surface_->to = std::max(surface_->to, along);
  } else {
    surface_ = Surface{at, along, along};
  }
}

double IrGuidance::grasp_reading() const {
  return folded_ && last_near_ ? *last_near_ : std::max(0.0, static_cast<double>(ir_->range_m));
}

bool IrGuidance::surface_ahead() const { return surface_ && surface_->to - surface_->from >= cfg_.ir_surface_travel; }

double IrGuidance::forward_speed(const Eigen::Isometry3d& tool, const Fruit& fruit, bool ir_sees_fruit,
                                 std::optional<double> hold_at) const {
  // Fast while far, then braking at a constant rate, so the arm reaches the
  // grasp range slowly: the stop overshoots by v^2 / 2a plus the travel
  // during one IR period. The IR range (palm to fruit surface) ends at the
  // grasp range about 2 cm before the estimate (tool point to fruit centre)
  // ends at zero, so the estimate is the longer of the two; it bounds the
  // IR's: the sensor's fold-back makes a fruit nearer than its peak read far,
  // and the arm must not speed up into it.
  const double ahead = ahead_along_axis(tool, fruit.estimate);
  double to_go = ahead;
  if (ir_sees_fruit) to_go = std::min(to_go, static_cast<double>(ir_->range_m) - cfg_.ir_grasp_range);
  // Passing a leaf: slow by its distance, the sensor then judges afresh what it reads (the "leaf" may be the fruit).
  if (leaf_at_) to_go = std::min(to_go, *leaf_at_ - along_axis(tool));
  if (split_close_at_) to_go = std::min(to_go, *split_close_at_ - along_axis(tool));
  if (hold_at) {
    // Standing off a swaying fruit: no floor, the arm comes to rest there.
    const double to_hold = ahead - *hold_at;
    return std::clamp(std::sqrt(2.0 * cfg_.ir_braking_decel * std::max(0.0, std::min(to_go, to_hold))), 0.0,
                      cfg_.ir_approach_speed);
  }
  return std::clamp(std::sqrt(2.0 * cfg_.ir_braking_decel * std::max(0.0, to_go)), cfg_.ir_min_speed,
                    cfg_.ir_approach_speed);
}

IrStep IrGuidance::step(rt::Micros now, const Eigen::Isometry3d& tool, const Fruit& fruit,
                        std::optional<double> fruit_in_front, std::optional<double> hold_at, bool seen_whole,
                        bool fruit_on_axis) {
  IrStep out;
  // The fold-back rule reads a tool moving in: a leaf or a neighbour in the beam of one standing off a fruit, then
  // gone from it as the tool moves again, is no fruit inside.
  if (hold_at) {
    folded_ = false;
    last_near_.reset();
  }
  const bool ir_fresh = ir_ && now - ir_rx_ <= rt::from_seconds(cfg_.timeouts.ir_stale);
  const bool at_grasp_range =
      (ir_fresh && (ir_->validity == ir_range_t::VALID || ir_->validity == ir_range_t::TOO_NEAR) &&
       ir_->range_m <= cfg_.ir_grasp_range) ||
      folded_;
  // Fruit centre ahead of the tool point by the camera-in-hand's estimate.
  const double ahead = ahead_along_axis(tool, fruit.estimate);
  // The IR sees the first thing on its axis: a leaf in front of the fruit
  // reads like the fruit. A reading at the grasp range while an estimate
  // checked against the rays' crossing puts the fruit much farther is that
  // leaf; the approach goes on past it. A depth from the apparent size alone
  // can be decimetres off, so it never overrules the IR. Not when a fruit
  // nearer than the one aimed at fills the hand image on the axis as the
  // reading comes: then the IR reads that fruit, and pushing on would knock
  // it off; the gripper closes on it instead.
  // Once the sensor is past the leaf, what it reads next is judged afresh: a
  // fruit beside the target on the axis, let through as "the leaf" still, was
  // pushed off the tree by the palm (15 of 20 fruit the palm knocked off in
  // 14 full-tree runs, the IR reading them at the grasp range and the hand
  // image filled with them).
  const double along = along_axis(tool);
  if (leaf_at_ && along >= *leaf_at_) leaf_at_.reset();
  const bool in_front = !leaf_at_ && fruit_in_front.has_value();
  // Until the sensor has come as far as the leaf was, a grasp reading is that leaf whatever the estimate says by
  // then: judged again each step, an estimate just over the limit (71 mm) closed 20 ms after "past a leaf" with the
  // fruit 54 mm ahead of the tool point, out of the fingers' reach (a full-tree run).
  // Not a size near the fruit that set a disagreeing crossing aside (kNear): usually right to a centimetre or two,
  // but a leaf-cut fruit that looks 2.5 times too far there would have its real IR reading passed as a leaf.
  // Whatever the depth's source, a fruit seen whole in a fresh hand image with its estimate a decimetre or more ahead
  // is far: a whole fruit's size errs by ~10 % of the camera's distance (2-3 cm there), and at the grasp range the
  // estimate is 0-5 cm ahead. In wind the rays' crossing disagrees with a fruit that has swung on, so its depth is the
  // size's alone (kSize, kNear) and two tree_wind runs closed 9 times on a leaf 12-55 cm before such a fruit (the
  // estimate 12-55 cm ahead, the fruit whole in the hand image within 0.3 s); the 30 closes at a fruit had it -1..4 cm
  // ahead. Not a fruit cut by the image border or filling it: its size is no depth.
  // A fruit covering the centre of a fresh hand image is near the palm, across the IR's beam: the reading is a fruit
  // whatever the estimate says. Two of ten tree runs' palm knocks were so (the estimate 55 and 61 mm ahead, the
  // crossing's depth too deep; the detection on the centre covering 0.89 and 0.73 of the image), where the 55
  // "leaves" the runs passed without a knock showed at most 0.41 and 95 % of their closes 0.54 or more.
  const bool checked = fruit.depth == Fruit::Depth::kConfirmed || fruit.depth == Fruit::Depth::kCrossing;
  const bool far_seen = seen_whole && cfg_.far_view_ahead > 0 && ahead >= cfg_.far_view_ahead;
  const bool beyond_estimate = cfg_.ir_vision_agreement > 0 && checked && ahead > cfg_.ir_vision_agreement;
  const bool far_in_view = far_seen && !fruit_on_axis;
  const bool beyond_agreement = beyond_estimate && !fruit_on_axis;
  // Leaf or fruit (ir_split_close): just beyond the agreement the reading was more often the fruit itself than a leaf
  // (the crossing's depth 3-6 cm too deep near the fruit: all 13 such "leaves" passed in ten tree runs with the learned
  // detectors came before a fruit knocked off by the palm), but closing at once knocks off a fruit that really
  // is that far with a finger (3 in five runs against 1). Going on half the gap between the centre the reading gives
  // and the estimate's, then closing, leaves both within the fingers' reach while the gap is small; ir_split_max bounds
  // the advance so the palm does not run into a fruit the IR read (25-26 mm did, twice), favouring the reading beyond
  // that.
  if (at_grasp_range && !in_front && !leaf_at_ && !split_close_at_ && beyond_agreement && !far_in_view &&
      ahead <= cfg_.ir_split_close) {
    const double range = grasp_reading();
    const double reading_ahead = range + 0.5 * fruit.diameter - cfg_.palm_offset;
    const double split = std::clamp(0.5 * (ahead - reading_ahead), 0.0, cfg_.ir_split_max);
    split_close_at_ = along + split;
    out.note = "IR at " + std::to_string(std::lround(range * 1000)) + " mm, fruit " +
               std::to_string(std::lround(ahead * 1000)) + " mm ahead: leaf or fruit, closing " +
               std::to_string(std::lround(split * 1000)) + " mm on";
  }
  if (at_grasp_range && !in_front && !leaf_at_ && !split_close_at_ && fruit_on_axis && (far_seen || beyond_estimate))
    out.note = "IR at " + std::to_string(std::lround(ir_->range_m * 1000)) + " mm, fruit " +
               std::to_string(std::lround(ahead * 1000)) + " mm ahead, a fruit over the hand image: no leaf";
  if (split_close_at_ && along >= *split_close_at_) {
    out.action = IrStep::Action::kClose;
    return out;
  }
  const bool leaf =
      at_grasp_range && !in_front && !split_close_at_ && (leaf_at_.has_value() || beyond_agreement || far_in_view);
  if (leaf) {  // the leaf, not the fruit
    if (!leaf_at_) leaf_at_ = along + grasp_reading();
    folded_ = false;
    last_near_.reset();
  }
  if (leaf && !leaf_noted_) {
    leaf_noted_ = true;
    out.note = "IR at " + std::to_string(std::lround(ir_->range_m * 1000)) + " mm, fruit " +
               std::to_string(std::lround(ahead * 1000)) + " mm ahead" + (far_in_view ? ", seen whole" : "") +
               ": past a leaf";
  }
  if (at_grasp_range && !leaf && !split_close_at_) {
    // A fruit in front of the one aimed at, too far off the gripper axis to
    // be captured: closing would knock it off with a finger, pushing on with
    // the palm. Leave it for its own turn; this fruit is tried again after it.
    if (in_front && *fruit_in_front > cfg_.front_fruit_tolerance) {
      out.action = IrStep::Action::kFruitInTheWay;
      out.offset = *fruit_in_front;
    } else {
      out.action = IrStep::Action::kClose;
    }
    return out;
  }
  // Progress is ir_progress_step of tool motion: a tool that makes none for
  // timeouts.stall is blocked (the arm at the edge of its reach, a joint
  // limit) and waits out nothing.
  const Eigen::Vector3d p = tool.translation();
  if ((p - progress_from_).norm() > cfg_.ir_progress_step || hold_at) {  // holding off a fruit is no stall
    progress_from_ = p;
    progress_at_ = now;
  }
  const bool blocked = now - progress_at_ > rt::from_seconds(cfg_.timeouts.stall);
  // Past the estimated centre the fruit was missed, unless the IR reads a surface that stays put ahead as the tool
  // comes on: the estimate's depth was short (from the apparent size it can be decimetres off; a full-tree run
  // backed off twice 5 cm past an estimate 10 cm short of the fruit the IR was reading 7 cm ahead, and gave it up).
  track_surface(tool);
  const double overshoot = cfg_.ir_overshoot + (ir_fresh && surface_ahead() ? cfg_.ir_surface_reach : 0.0);
  if ((p - start_).norm() > cfg_.ir_max_travel || ahead < -overshoot || blocked) {
    out.action = IrStep::Action::kGiveUp;
    return out;
  }
  if (!ir_fresh) {
    out.action = IrStep::Action::kHold;
    return out;
  }
  out.action = IrStep::Action::kAdvance;
  out.forward_speed = forward_speed(tool, fruit, ir_->validity == ir_range_t::VALID && !leaf, hold_at);
  return out;
}

std::optional<Twist> IrGuidance::grasp_twist(const Eigen::Isometry3d& tool) const {
  const Eigen::Vector3d axis = tool.rotation().col(2);
  if (advance_stopped_ || (tool.translation() - grasp_from_).dot(axis) >= cfg_.grasp_advance) return std::nullopt;
  Twist forward;
  forward.linear = cfg_.ir_min_speed * axis;
  return forward;
}

}  // namespace harvest::servo
