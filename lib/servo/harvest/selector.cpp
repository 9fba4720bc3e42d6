#include "servo/harvest/selector.hpp"

#include <algorithm>
#include <tuple>

#include "servo/geometry.hpp"
#include "servo/harvest/aiming.hpp"

namespace harvest::servo {

Selection select_fruit(const ServoConfig& cfg, const targets_t& view, FruitLedger& ledger,
                       const Eigen::Vector3d& aim_from, rt::Micros now,
                       const std::optional<Eigen::Matrix3d>& travel_from) {
  Selection out;
  const target_t* best = nullptr;
  double best_key = 0.0;
  // Every fruit is aimed at from home: the turn to it from where the tool
  // points now is the travel before the hand camera sees it.
  const bool by_travel = cfg.fruit_order == "travel" && travel_from;
  auto order_key = [&](const target_t& t, const Fruit& f) {
    if (!by_travel) return static_cast<double>(t.cost);
    Eigen::Isometry3d home = cfg.home_pose;
    home.translation() = aim_from;
    return rotation_distance(*travel_from, aim_rotation(home, f.estimate));
  };
  for (const auto& t : view.targets) {
    const Eigen::Vector3d p(t.position_base[0], t.position_base[1], t.position_base[2]);
    const Eigen::Vector3d camera(view.camera_position_base[0], view.camera_position_base[1],
                                 view.camera_position_base[2]);
    // The fixed camera's line of sight to it: a depth from the apparent size
    // may jump by decimetres from image to image, the direction does not.
    std::optional<Eigen::Vector3d> sight;
    if (view.camera_known && (p - camera).norm() > 1e-6) sight = (p - camera).normalized();
    if (!ledger.selectable(t.fruit_id, p, sight)) continue;
    Fruit f{t.fruit_id, p, now, p, sight_line(cfg, view, t), false};
    if (t.diameter_m > 0) f.diameter = t.diameter_m;
    if (!pickable(cfg, p)) {
      // The fixed camera's depth comes from the fruit's apparent size, its
      // direction from the calibration: a piece of a fruit looks small and
      // far, fruit side by side look large and near. Aim at the part of the
      // line of sight where a fruit can be picked, nearest the estimate, and
      // let the camera-in-hand measure it (eq. 6-15); only a line of sight
      // that never gets there is unreachable.
      if (!f.sight) {
        ledger.use_up_attempts(t.fruit_id);
        const char* why = view.camera_known           ? "out of reach along its whole line of sight"
                          : cfg.workspace.contains(p) ? "not ahead of the gripper at home"
                                                      : "outside the reachable workspace";
        out.rejected.push_back(ledger.record(fruit_outcome_t::UNREACHABLE, t.fruit_id, p, why, 0.0, aim_from, nullptr));
        continue;
      }
      const double s = std::clamp((p - f.sight->origin).dot(f.sight->direction), f.sight->near, f.sight->far);
      f.estimate = sight_aim(cfg, *f.sight, s, aim_from);
      f.depth_doubtful = true;
    }
    const double key = order_key(t, f);
    if (best == nullptr ||
        std::make_tuple(ledger.attempts(t.fruit_id), f.depth_doubtful, key, t.fruit_id) <
            std::make_tuple(ledger.attempts(best->fruit_id), out.fruit->depth_doubtful, best_key, best->fruit_id)) {
      best = &t;
      best_key = key;
      out.fruit = f;
    }
  }
  return out;
}

}  // namespace harvest::servo
