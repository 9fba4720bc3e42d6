#include "calib/plan_cli.hpp"

#include <fmt/format.h>

#include <iostream>

#include "arm/robot_link_config.hpp"
#include "calib/calibration_node.hpp"
#include "calib/link_reach.hpp"
#include "calib/live_run.hpp"
#include "calib/report.hpp"
#include "calib/solvers.hpp"
#include "geometry/transform_file.hpp"
#include "runtime/channels.hpp"
#include "security/authority.hpp"

namespace harvest::calib {
namespace {

// The plan with each pose the link would refuse replaced by a reachable
// variant where there is one (checked offline from the arm's joints now).
std::vector<Eigen::Isometry3d> reachable_poses(
    const PlanRequest& r, const Eigen::VectorXd& q,
    const std::function<std::vector<Eigen::Isometry3d>(const PoseVariant&)>& make, std::ostream& out) {
  if (r.robot_link_file.empty()) return make(PoseVariant{});
  if (q.size() == 0) {
    out << "no joints on ROBOT_STATE: the poses' reachability is not checked\n";
    return make(PoseVariant{});
  }
  config::Document doc = config::Document::load_file(r.robot_link_file);
  LinkReach reach(arm::RobotLinkConfig::from_config(doc.root()), q, r.run.max_linear_speed, r.run.max_angular_speed);
  std::vector<std::string> refusals;
  const ReachablePlan p = choose_reachable(make, [&](const Eigen::Isometry3d& pose) {
    std::string why;
    const bool ok = reach.accept(pose, &why);
    if (!ok) refusals.push_back(why);
    return ok;
  });
  out << fmt::format("reachability ({}, the robot link's own checks): {} of {} poses as planned, {} by a variant, {} "
                     "by none (the link will refuse them: skipped)\n",
                     r.robot_link_file, p.nominal(), p.poses.size(), p.held() - p.nominal(),
                     static_cast<int>(p.poses.size()) - p.held());
  for (std::size_t k = 0; k < p.variant.size(); ++k) {
    if (p.variant[k] == 0) continue;
    if (p.variant[k] < 0) {
      out << fmt::format("  pose {:2d}: no reachable variant\n", k + 1);
      continue;
    }
    const PoseVariant& v = fallback_variants()[static_cast<std::size_t>(p.variant[k] - 1)];
    out << fmt::format("  pose {:2d}: tilt x{:.1f}, roll x{:.0f}, distance {:+.0f} mm\n", k + 1, v.tilt_scale,
                       v.roll_scale, 1000 * v.distance_change_m);
  }
  return p.poses;
}

}  // namespace
int run_plan(const PlanRequest& r, std::ostream& out, std::ostream& err) {
  const bool hand_eye = r.procedure == "hand-eye";
  try {
    const geometry::CameraModel camera = geometry::CameraModel::load(r.intrinsics_file);
    const Eigen::Isometry3d estimate =
        hand_eye ? geometry::load_transform_file(r.hand_eye_file, geometry::Handedness::kProper)
                 : geometry::load_transform_file(r.extrinsic_file, geometry::Handedness::kReflectionAllowed);

    // 1. The board in the camera's view, the arm at rest (the collector's rules).
    CalibrationNodeConfig cfg;
    cfg.image_channel = !r.image_channel.empty() ? r.image_channel
                        : hand_eye               ? channels::kCameraHand
                                                 : channels::kCameraFixed;
    cfg.robot_state_channel = channels::kRobotState;
    cfg.board = r.board;
    cfg.collect.max_views = 1;
    CalibrationNode locator(cfg);
    locator.on_view = [&](const BoardView&, Verdict v) {
      if (v == Verdict::kAccepted) stop_live();
    };
    err << "looking for the board on " << cfg.image_channel << " with the arm at rest (up to " << r.locate_timeout_s
        << " s)\n";
    run_live(locator, r.lcm_url, r.prefix, r.locate_timeout_s);
    locator.finish();
    if (locator.collector().views().empty())
      throw CalibrationError(fmt::format(
          "the board was not seen on {} with the arm at rest within {:.0f} s ({}): put it in the camera's view, "
          "square on, about {:.0f} mm away, and hold the arm still",
          cfg.image_channel, r.locate_timeout_s, locator.collector().summary(),
          1000 * (hand_eye ? r.hand_eye.distance_m : r.extrinsics.distance_m)));
    const BoardView& view = locator.collector().views().front();
    const Eigen::Isometry3d tool = *view.tool_pose;
    const Eigen::Isometry3d in_camera = board_in_camera(view, locator.board(), camera);

    // 2. The poses around it, from the current estimates.
    std::vector<Eigen::Isometry3d> poses;
    if (hand_eye) {
      const Eigen::Isometry3d board_in_base = tool * estimate * in_camera;
      out << pose_line("board in the base frame", board_in_base) << "\n";
      poses = reachable_poses(r, locator.last_joints(), [&](const PoseVariant& v) {
        return plan_hand_eye(board_in_base, r.board, estimate, r.hand_eye, v);
      }, out);
    } else {
      // A mirrored view's pose is in the camera's proper twin.
      const Eigen::Isometry3d board_in_base = (view.mirrored ? proper_twin(estimate) : estimate) * in_camera;
      const Eigen::Isometry3d board_in_tool = tool.inverse() * board_in_base;
      out << pose_line("board on the tool", board_in_tool) << "\n";
      poses = reachable_poses(r, locator.last_joints(), [&](const PoseVariant& v) {
        return plan_extrinsics(estimate, r.board, board_in_tool, r.extrinsics, v);
      }, out);
    }
    check_rotation_diversity(poses, PoseOptions{});
    out << pose_line("tool now", tool) << "\n";
    for (std::size_t k = 0; k < poses.size(); ++k)
      out << pose_line(fmt::format("pose {:2d}", k + 1), poses[k]) << "\n";
    if (!r.move) {
      out << "not moving (give --run to move the arm through these poses while recording)\n";
      return 0;
    }

    // 3. Through the robot link, the operator recording.
    PlanRunConfig run = r.run;
    run.poses = poses;
    const std::string key = r.key.empty() ? security::default_command_key() : r.key;
    PlanRunner runner(run, security::load_named_key(key), r.sender);
    runner.on_progress = [&](const std::string& line) { out << line << "\n" << std::flush; };
    out << fmt::format(
               "moving through {} poses at most {:.2f} m/s, {:.2f} rad/s, resting {:.1f} s at each; Ctrl-C stops the "
               "arm\n",
               poses.size(), run.max_linear_speed, run.max_angular_speed, run.dwell_s)
        << std::flush;
    run_live(runner, r.lcm_url, r.prefix, 0);
    if (runner.outcome() != PlanRunner::Outcome::kDone) {
      err << "harvest-calibrate: plan stopped: " << runner.why() << "\n";
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    err << "harvest-calibrate: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace harvest::calib
