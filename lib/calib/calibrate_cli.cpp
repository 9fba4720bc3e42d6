#include "calib/calibrate_cli.hpp"

#include <CLI/CLI.hpp>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibration_node.hpp"
#include "calib/live_run.hpp"
#include "calib/plan_cli.hpp"
#include "calib/report.hpp"
#include "geometry/transform_file.hpp"
#include "runtime/channels.hpp"
#include "runtime/replay_runner.hpp"

namespace harvest::calib {
namespace {

struct Source {
  std::string log, lcm_url, prefix;
  double duration_s = 0.0;
};

// Runs the node over the log, or live until it has its views, the duration
// is over or Ctrl-C.
void collect(CalibrationNode& node, const Source& src, std::ostream& err) {
  node.on_view = [&err, &node](const BoardView& v, Verdict verdict) {
    if (verdict == Verdict::kAccepted)
      err << "view " << node.collector().views().size() << ": " << v.ids.size() << " corners, sharpness "
          << static_cast<int>(v.sharpness) << (v.mirrored ? ", mirrored" : "") << "\n";
  };
  if (!src.log.empty()) {
    rt::ReplayOptions ro;
    ro.input_log = src.log;
    ro.prefix = src.prefix;
    rt::ReplayRunner runner(ro);
    runner.add(node);
    runner.run();
  } else {
    err << "collecting views live; Ctrl-C when done\n";
    run_live(node, src.lcm_url, src.prefix, src.duration_s);
  }
  node.finish();
  err << node.collector().summary() << "\n";
}

void write_text(const std::string& path, const std::string& text, std::ostream& out) {
  if (path.empty() || path == "-") {
    out << text;
    return;
  }
  std::ofstream f(path, std::ios::binary);
  if (!(f << text)) throw std::runtime_error(path + ": cannot write");
}

void write_png(const std::string& path, const cv::Mat& img) {
  if (path.empty()) return;
  // No time chunks: the same report gives the same bytes.
  if (!cv::imwrite(path, img, {cv::IMWRITE_PNG_COMPRESSION, 6})) throw std::runtime_error(path + ": cannot write");
}

std::string board_line(const BoardSpec& b) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "%d x %d ChArUco board, %.1f mm squares, %.1f mm markers, %s", b.squares_x,
                b.squares_y, b.square_m * 1000, b.marker_m * 1000, b.dictionary.c_str());
  return buf;
}

}  // namespace

int calibrate_main(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app("Camera calibration from a recorded log or live LCM: intrinsics, hand-eye, fixed-camera extrinsics",
               "harvest-calibrate");
  app.require_subcommand(1);
  Source src;
  BoardSpec board;
  std::vector<int> squares{board.squares_x, board.squares_y};
  double square_mm = board.square_m * 1000, marker_mm = board.marker_m * 1000;
  std::string output, report, date, intrinsics_file, camera, channel, state_channel = channels::kRobotState;
  CalibrationNodeConfig cfg;
  IntrinsicsOptions iopt;
  PoseOptions popt;
  int min_views = 0, max_views = 0;

  auto board_options = [&](CLI::App* c) {
    c->add_option("--squares", squares, "board squares across and down")->expected(2)->capture_default_str();
    c->add_option("--square-mm", square_mm, "board square side [mm]")->capture_default_str();
    c->add_option("--marker-mm", marker_mm, "board marker side [mm]")->capture_default_str();
    c->add_option("--dictionary", board.dictionary, "ArUco dictionary of the board")
        ->check(CLI::IsMember(board_dictionaries()))
        ->capture_default_str();
  };
  auto common = [&](CLI::App* c) {
    auto* g = c->add_option_group("source", "where the frames come from");
    g->add_option("--log", src.log, "a recorded LCM log (replayed in process, as fast as the CPU allows)");
    g->add_option("--lcm-url", src.lcm_url, "live LCM (collect until Ctrl-C, --views or --duration)");
    g->require_option(1);
    c->add_option("--prefix", src.prefix, "channel prefix of the recorded graph");
    c->add_option("--channel", channel, "image channel (default: the procedure's camera)");
    board_options(c);
    c->add_option("-o,--output", output, "the calibration file to write (default: standard output)");
    c->add_option("--report", report, "a PNG report: error vectors over the image, per-view residuals");
    c->add_option("--date", date, "the date in the file's comment (default: the last frame's time, UTC)");
    c->add_option("--min-views", min_views, "refuse to solve from fewer views")->check(CLI::PositiveNumber);
    c->add_option("--views", max_views, "stop after this many accepted views")->check(CLI::PositiveNumber);
    c->add_option("--duration", src.duration_s, "live: stop collecting after this many seconds");
    c->add_option("--min-sharpness", cfg.collect.min_sharpness,
                  "a view with a lower variance of the Laplacian over the board is blurred")
        ->capture_default_str();
  };
  auto* intr = app.add_subcommand("intrinsics", "focal length, principal point, 5-coefficient distortion");
  intr->add_option("camera", camera, "fixed or hand")->required()->check(CLI::IsMember({"fixed", "hand"}));
  common(intr);
  auto* he = app.add_subcommand("hand-eye", "the camera-in-hand pose on the tool, arm moved about a fixed board");
  he->add_option("--intrinsics", intrinsics_file, "the hand camera's calibration")->required();
  he->add_option("--robot-state-channel", state_channel, "arm state channel")->capture_default_str();
  common(he);
  auto* ex = app.add_subcommand("extrinsics", "the fixed camera in the base frame, a board carried by the tool");
  ex->add_option("--intrinsics", intrinsics_file, "the fixed camera's calibration")->required();
  ex->add_option("--robot-state-channel", state_channel, "arm state channel")->capture_default_str();
  common(ex);

  PlanRequest plan;
  plan.hand_eye_file = "config/cameras/hand_eye.yaml";
  plan.extrinsic_file = "config/cameras/fixed_extrinsic.yaml";
  double plan_distance_mm = 0, plan_tilt_deg = 0;
  auto* pl = app.add_subcommand(
      "plan", "arm poses about the board in view for hand-eye or extrinsics; with --run, moves the arm through them");
  pl->add_option("procedure", plan.procedure, "hand-eye or extrinsics")
      ->required()
      ->check(CLI::IsMember({"hand-eye", "extrinsics"}));
  pl->add_option("--lcm-url", plan.lcm_url, "LCM URL of the robot's network (default: $LCM_DEFAULT_URL)");
  pl->add_option("--prefix", plan.prefix, "channel prefix of the robot's graph");
  pl->add_option("--channel", plan.image_channel, "image channel (default: the procedure's camera)");
  pl->add_option("--intrinsics", plan.intrinsics_file, "the procedure's camera calibration")->required();
  pl->add_option("--hand-eye", plan.hand_eye_file, "hand-eye: the current camera-in-hand estimate")
      ->capture_default_str();
  pl->add_option("--extrinsic", plan.extrinsic_file, "extrinsics: the current fixed-camera estimate")
      ->capture_default_str();
  pl->add_option("--robot-link-config", plan.robot_link_file,
                 "the robot link's configuration: a pose it would refuse is replaced by a reachable variant before "
                 "moving ('' : no check)")
      ->capture_default_str();
  pl->add_option("--poses", plan.hand_eye.poses, "hand-eye: poses on the ring about the board")
      ->check(CLI::Range(6, 60))
      ->capture_default_str();
  pl->add_option("--distance-mm", plan_distance_mm,
                 "camera to board at the nearest pose (default 450 hand-eye, 600 extrinsics)")
      ->check(CLI::Range(200.0, 2000.0));
  pl->add_option("--tilt-deg", plan_tilt_deg, "board tilt off square-on (default 25)")->check(CLI::Range(5.0, 45.0));
  pl->add_option("--speed", plan.run.max_linear_speed, "tool speed [m/s] (the robot link's limits still apply)")
      ->check(CLI::Range(0.01, 0.5))
      ->capture_default_str();
  pl->add_option("--dwell", plan.run.dwell_s, "rest at each pose [s]")
      ->check(CLI::Range(0.3, 30.0))
      ->capture_default_str();
  pl->add_option("--pose-timeout", plan.run.pose_timeout_s, "skip a pose not reached in this long [s]")
      ->check(CLI::Range(2.0, 600.0))
      ->capture_default_str();
  pl->add_option("--locate-timeout", plan.locate_timeout_s, "wait this long for the board in view [s]")
      ->capture_default_str();
  pl->add_option("--key", plan.key, "command key: sim or a key file (default: $HARVEST_COMMAND_KEY, else sim)");
  pl->add_option("--sender", plan.sender, "sender id the robot link obeys (its authority.controller)")
      ->capture_default_str();
  pl->add_flag("--run", plan.move, "move the arm through the poses (without: print the plan only)");
  board_options(pl);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e, out, err);
    return rc == 0 ? 0 : 2;
  }

  if (pl->parsed()) {
    board.squares_x = squares[0];
    board.squares_y = squares[1];
    board.square_m = square_mm / 1000;
    board.marker_m = marker_mm / 1000;
    plan.board = board;
    if (plan_distance_mm > 0) plan.hand_eye.distance_m = plan.extrinsics.distance_m = plan_distance_mm / 1000;
    if (plan_tilt_deg > 0) plan.hand_eye.tilt_deg = plan.extrinsics.tilt_deg = plan_tilt_deg;
    return run_plan(plan, out, err);
  }
  try {
    board.squares_x = squares[0];
    board.squares_y = squares[1];
    board.square_m = square_mm / 1000;
    board.marker_m = marker_mm / 1000;
    cfg.board = board;
    cfg.collect.max_views = max_views;
    const bool arm = !intr->parsed();
    if (channel.empty())
      channel = intr->parsed() ? (camera == "fixed" ? channels::kCameraFixed : channels::kCameraHand)
                : he->parsed() ? channels::kCameraHand
                               : channels::kCameraFixed;
    cfg.image_channel = channel;
    if (arm) cfg.robot_state_channel = state_channel;
    if (min_views > 0) iopt.min_views = popt.min_views = min_views;

    geometry::CameraModel cam;
    if (arm) cam = geometry::CameraModel::load(intrinsics_file);
    CalibrationNode node(cfg);
    collect(node, src, err);
    const auto& views = node.collector().views();
    const std::string when = date.empty() ? utc_date(node.last_frame_utime()) : date;
    const std::string source = src.log.empty() ? "live LCM" : src.log;
    const std::string head = "harvest-calibrate " +
                             std::string(intr->parsed() ? "intrinsics " + camera
                                         : he->parsed() ? "hand-eye"
                                                        : "extrinsics") +
                             ", " + when + ", " + channel + " from " + source + "\n" + board_line(board) + "; " +
                             node.collector().summary() + "\n";
    if (intr->parsed()) {
      const IntrinsicsResult r = solve_intrinsics(views, node.board(), iopt);
      const std::string text = intrinsics_comment(r);
      write_text(output, camera_yaml(r.model, head + text), out);
      write_png(report, report_image("intrinsics " + camera + ": RMS " + std::to_string(r.rms_px).substr(0, 6) +
                                         " px, " + std::to_string(views.size()) + " views",
                                     views.front().image_size, r.views, r.uncovered, false));
      err << text;
    } else if (he->parsed()) {
      const HandEyeResult r = solve_hand_eye(views, node.board(), cam, popt);
      const std::string text = hand_eye_comment(r);
      write_text(output,
                 geometry::transform_yaml(r.camera_in_tool, head + "intrinsics " + intrinsics_file + "\n" + text), out);
      write_png(report, report_image("hand-eye: RMS " + std::to_string(r.rms_px).substr(0, 6) +
                                         " px through the arm, " + std::to_string(views.size()) + " views",
                                     views.front().image_size, r.views, {}, true));
      err << text;
    } else {
      const ExtrinsicsResult r = solve_extrinsics(views, node.board(), cam, popt);
      const std::string text = extrinsics_comment(r);
      write_text(output,
                 geometry::transform_yaml(r.camera_in_base, head + "intrinsics " + intrinsics_file + "\n" + text), out);
      write_png(report, report_image("extrinsics: RMS " + std::to_string(r.rms_px).substr(0, 6) +
                                         " px through the arm, " + std::to_string(views.size()) + " views",
                                     views.front().image_size, r.views, {}, true));
      err << text;
    }
    return 0;
  } catch (const std::exception& e) {
    err << "harvest-calibrate: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace harvest::calib
