#include "servo/harvest/wind.hpp"

#include <fmt/format.h>

namespace harvest::servo {

void WindWatch::new_fruit() {
  sway_.reset();
  hold_since_.reset();
  held_ = false;
  still_after_all_ = false;
}

void WindWatch::add(int64_t image_utime, const Eigen::Vector3d& across_axis) {
  fed_ = image_utime;
  sway_.add(rt::to_seconds(image_utime), across_axis);
}

bool WindWatch::tree_still(rt::Micros now) const {
  return tree_.reading().verdict == TreeSwayGauge::Verdict::kStill &&
         now - fixed_rx_ <= rt::from_seconds(p_.tree_window);  // a verdict no older than its window
}

WindWatch::Hold WindWatch::hold(rt::Micros now, double ahead, Fruit::Depth depth, bool whole) {
  // The centring follows the fruit's mean over gains.sway_window, but IR guidance takes about a second, less than
  // a period of a slow sway: the mean of part of a swing lies up to 3/4 of its amplitude off the sway's middle, and
  // the jaws close beside a fruit that swings on (docs/servo-controller.md, "A fruit in the wind"). A fruit seen to
  // sway is watched from the standoff, the arm at rest and the fruit whole in the image, until the mean is over
  // whole periods; then the approach goes in on it.
  if (held_ || p_.hold_standoff <= 0.0 || p_.hold_time <= 0.0) return {};
  if (!hold_since_) {
    // Not a fruit cut by a leaf (its depth from the rays' crossing or the fixed camera, the hand's size
    // disagreed): the standoff would be measured from a doubtful depth, and the hand camera's views of it are pieces.
    const double spread = sway_.spread();
    if (spread <= p_.hold_spread || depth == Fruit::Depth::kCrossing || depth == Fruit::Depth::kFixed) return {};
    if (p_.tree_still_skips_hold && tree_still(now)) {
      // The fixed camera, standing still, sees the tree still: the spread is the moving hand camera's error
      // (depth, pose timing, pieces of the fruit), not a sway.
      held_ = true;
      const TreeSwayGauge::Reading& tree = tree_.reading();
      return {std::nullopt, fmt::format("the tree is still ({:.1f} mm rms over {} fruit in the fixed camera): {:.0f} "
                                        "mm rms across the axis not held for",
                                        tree.rms * 1e3, tree.fruit, spread * 1e3)};
    }
    if (ahead > p_.hold_standoff + p_.at_standoff) return {p_.hold_standoff, std::nullopt};  // on the way there
    if (!whole) {  // there (or past it), the fruit not whole in the image: nothing to watch, go on
      held_ = true;
      return {};
    }
    hold_since_ = now;
    return {p_.hold_standoff, fmt::format("swaying ({:.0f} mm rms across the axis): held {:.0f} mm short of it for "
                                          "{:.1f} s",
                                          spread * 1e3, ahead * 1e3, p_.hold_time)};
  }
  const rt::Micros held_for = now - *hold_since_;
  if (p_.hold_check > 0.0 && held_for >= rt::from_seconds(p_.hold_check) && held_for < rt::from_seconds(p_.hold_time)) {
    // Early word from the views taken since the hold began, the arm at rest: a still fruit that looked to sway
    // (seen while the arm moved and turned, its spread is the depth error's sideways share) spreads by the pixel
    // noise alone, a swaying one by its sway. On ten still short trees 10 of 37 IR approaches held the whole 2.5 s;
    // their held spreads were 0.1-1.0 mm, swaying fruit's in tree_wind 4.4-13.6 mm, but once 0.4 mm: a sway along
    // the gripper axis hardly spreads across it (docs/servo-controller.md).
    const auto spread = sway_.spread_since(rt::to_seconds(*hold_since_));
    std::string note;
    if (fed_ <= *hold_since_) {
      note = fmt::format("not seen whole in {:.1f} s held: going in", rt::to_seconds(held_for));
    } else if (spread && *spread < p_.still_spread) {
      still_after_all_ = true;
      note = fmt::format("still after all ({:.1f} mm rms over {:.1f} s held): going in", *spread * 1e3,
                         rt::to_seconds(held_for));
    } else if (tree_still(now)) {
      // The fixed camera, standing still, sees the tree still: the held views spread by the hand camera's noise
      // and pieces of the fruit, not by a sway. Going in without any hold was faster but less accurate: the hold
      // is also where the arm, at rest, centres on whole views (ten still trees: final error 10.0 mm without it,
      // 8.5 mm with it; docs/demo.md).
      still_after_all_ = true;
      const TreeSwayGauge::Reading& tree = tree_.reading();
      note =
          fmt::format("the tree is still ({:.1f} mm rms over {} fruit in the fixed camera; {:.1f} mm held): going in",
                      tree.rms * 1e3, tree.fruit, spread.value_or(0.0) * 1e3);
    } else {
      return {p_.hold_standoff, std::nullopt};
    }
    held_ = true;
    return {std::nullopt, note};
  }
  if (held_for < rt::from_seconds(p_.hold_time)) return {p_.hold_standoff, std::nullopt};
  held_ = true;
  const auto spread = sway_.spread_since(rt::to_seconds(*hold_since_));
  return {std::nullopt, spread ? fmt::format("held {:.1f} s ({:.1f} mm rms while held): going in",
                                             rt::to_seconds(held_for), *spread * 1e3)
                               : fmt::format("held {:.1f} s: going in", rt::to_seconds(held_for))};
}

WindWatch::Close WindWatch::close(rt::Micros now, const Eigen::Isometry3d& tool, double waited_s, double step_s) const {
  // A swaying fruit: closed on when it is predicted on the gripper axis as the jaws meet; held still until then.
  const SwayFit fit = tree_still(now) ? SwayFit{} : sway_.fit();  // still: at once, as without wind
  Close c{close_decision(fit, tool, rt::to_seconds(now), waited_s, step_s, p_), std::nullopt};
  if (c.decision.close && fit.swaying)
    c.note = fmt::format(
        "swaying {:.0f} mm at {:.2f} Hz{} (fit {:.2f}): closed after {:.2f} s, predicted {:.0f} mm "
        "off the axis",
        fit.amplitude * 1e3, fit.frequency_hz, fit.learned_frequency ? " (learned)" : "", fit.confidence, waited_s,
        c.decision.offset * 1e3);
  return c;
}

}  // namespace harvest::servo
