// harvest-vision-eval LOG --config DETECTOR.yaml --scenario SCENARIO.yaml: runs the fruit detector over a
// log's fixed-camera frames and scores it against the simulator's truth (SIM_TRUTH): per true fruit at
// least --min-visible visible, how many detections lie on it and how far their diameter is from the
// fruit's true apparent diameter (docs/perception.md, "Simulated tree").
#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/config.hpp"
#include "harvest/image_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "runtime/log_io.hpp"
#include "vision/camera_model.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/image_codec.hpp"
#include "vision/nodes.hpp"

using namespace harvest;

namespace {

struct Truth {
  Eigen::Vector2d centre;  // sensor px
  double diameter_px = 0;  // mean of the silhouette's x and y extents
  double depth_m = 0;
  double visible = 0;
  int id = 0;
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / static_cast<double>(v.size());
}
double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, config_file, scenario_file = "config/scenarios/tree.yaml", overlay;
  std::vector<std::string> overrides;
  int first = 0, count = 60, every = 1, verbose_frames = 0;
  double min_visible = 0.5;
  std::string camera = "fixed";
  CLI::App app("Fixed-camera fruit detector against the simulator's truth", "harvest-vision-eval");
  app.add_option("log", log_path, "LCM log with CAMERA_FIXED and SIM_TRUTH")->required();
  app.add_option("--config,-c", config_file, "detector configuration")->required();
  app.add_option("--set", overrides, "override KEY.PATH=VALUE (repeatable)");
  app.add_option("--scenario", scenario_file, "scenario with cameras.fixed and cameras.fixed_extrinsic_truth");
  app.add_option("--first", first, "first frame index");
  app.add_option("--count", count, "frames to score");
  app.add_option("--every", every, "every n-th frame");
  app.add_option("--min-visible", min_visible, "score fruit at least this visible");
  app.add_option("--camera", camera, "fixed, or hand (pose from SIM_TRUTH; no visibility: every fruit in view)")
      ->check(CLI::IsMember({"fixed", "hand"}));
  app.add_option("--verbose", verbose_frames, "print per-fruit lines for this many frames");
  std::vector<int> crop;
  app.add_option("--crop", crop, "with --overlay: also write this sensor-pixel rectangle x y w h, 3x")->expected(4);
  app.add_option("--overlay", overlay, "write frames with detections (cyan) and truth (green) to this folder");
  CLI11_PARSE(app, argc, argv);

  auto doc = config::Document::load_file(config_file);
  for (const auto& o : overrides) doc.apply_override(o);
  const auto node_config = vision::DetectorNodeConfig::from_yaml(doc.root());
  vision::FruitDetector detector(node_config.detector, node_config.calibration.fx, node_config.calibration.fy);

  // The true camera (the simulator's): intrinsics of the KPCS20-CP1 at sensor resolution, the scenario's
  // distortion and extrinsic.
  const auto scen = config::Document::load_file(scenario_file);
  const auto cams = scen.root().child("cameras");
  vision::CameraModel truth_cam;
  truth_cam.fx = 833.57, truth_cam.fy = 767.02, truth_cam.cx = 319.5, truth_cam.cy = 239.5;
  truth_cam.width = 640, truth_cam.height = 480;
  const auto dist = cams.child(camera).numbers("distortion_coefficients", {0, 0, 0, 0, 0}, 5);
  std::copy(dist.begin(), dist.end(), truth_cam.dist.begin());
  const auto rv = cams.child("fixed_extrinsic_truth").numbers("rotation", 9);
  const auto tv = cams.child("fixed_extrinsic_truth").numbers("translation_mm", 3);
  Eigen::Matrix3d rot;
  rot << rv[0], rv[1], rv[2], rv[3], rv[4], rv[5], rv[6], rv[7], rv[8];
  Eigen::Vector3d pos(tv[0] * 1e-3, tv[1] * 1e-3, tv[2] * 1e-3);
  const double f_mean = 0.5 * (node_config.calibration.fx + node_config.calibration.fy);
  const double d_o = node_config.detector.fruit_diameter_m;

  const auto log = rt::read_log(log_path);
  std::optional<sim_truth_t> truth;
  int index = -1, scored_frames = 0;
  std::map<int, int> histogram;  // detections per scored fruit -> fruit
  std::vector<double> diam_err_best, diam_err_all, frag_err;
  std::map<int, std::vector<double>> depth_err_bins;     // 100 mm bins of true depth -> error [mm]
  std::map<int, std::vector<double>> depth_err_largest;  // the same, largest detection per fruit only
  int unmatched = 0, detections_total = 0;
  double detect_ms = 0;
  if (!overlay.empty()) std::filesystem::create_directories(overlay);

  for (const auto& r : log) {
    if (r.channel == "SIM_TRUTH") {
      truth = rt::decode<sim_truth_t>(r.data);
      continue;
    }
    if (r.channel != (camera == "hand" ? "CAMERA_HAND" : "CAMERA_FIXED")) continue;
    ++index;
    if (index < first || (index - first) % every != 0 || !truth) continue;
    if (scored_frames >= count) break;
    const auto img = rt::decode<image_t>(r.data);
    if (!img) continue;
    const auto decoded = vision::decode_image(*img);
    if (!decoded.ok()) continue;
    const cv::Rect2d roi = vision::image_roi(*img);
    const double sx = roi.width / decoded.bgr.cols, sy = roi.height / decoded.bgr.rows;
    const auto t0 = std::chrono::steady_clock::now();
    const auto det = detector.detect(decoded.bgr);
    detect_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ++scored_frames;

    // Truth in sensor pixels: the silhouette of each sphere (its limb circle) projected.
    std::vector<Truth> fruits;
    if (camera == "hand") {
      const auto& o = truth->hand_camera_pose.orientation;
      rot = Eigen::Quaterniond(o[0], o[1], o[2], o[3]).normalized().toRotationMatrix();
      pos = Eigen::Vector3d(truth->hand_camera_pose.position[0], truth->hand_camera_pose.position[1],
                            truth->hand_camera_pose.position[2]);
    }
    for (const auto& f : truth->fruits) {
      if (f.state != sim_fruit_truth_t::ON_TREE) continue;
      const Eigen::Vector3d p =
          rot.transpose() * (Eigen::Vector3d(f.position_base[0], f.position_base[1], f.position_base[2]) - pos);
      if (p.z() < 0.1) continue;
      const double rr = 0.5 * f.diameter_m, d2 = p.squaredNorm();
      const Eigen::Vector3d c = p * (1 - rr * rr / d2);
      const double rho = rr * std::sqrt(1 - rr * rr / d2);
      const Eigen::Vector3d a = p.cross(Eigen::Vector3d::UnitY()).normalized(), b = p.cross(a).normalized();
      double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
      for (int k = 0; k < 72; ++k) {
        const double t = k * 2 * M_PI / 72;
        const Eigen::Vector2d q = truth_cam.project(c + rho * (std::cos(t) * a + std::sin(t) * b));
        x0 = std::min(x0, q.x()), x1 = std::max(x1, q.x()), y0 = std::min(y0, q.y()), y1 = std::max(y1, q.y());
      }
      Truth t;
      t.centre = truth_cam.project(p);
      t.diameter_px = 0.5 * ((x1 - x0) + (y1 - y0));
      t.depth_m = p.z();
      t.visible = camera == "hand" ? 1.0f : f.visible_fraction_fixed;
      t.id = f.sim_id;
      if (t.centre.x() < -t.diameter_px || t.centre.y() < -t.diameter_px || t.centre.x() > 640 + t.diameter_px ||
          t.centre.y() > 480 + t.diameter_px)
        continue;
      fruits.push_back(t);
    }
    // Each detection goes to the fruit whose disc holds its centre, nearest relative to its radius.
    std::vector<std::vector<std::pair<double, double>>> on(fruits.size());  // (diameter, u) per fruit
    for (const auto& d : det.fruits) {
      ++detections_total;
      const Eigen::Vector2d c((d.u + 0.5) * sx + roi.x - 0.5, (d.v + 0.5) * sy + roi.y - 0.5);
      const double diameter = d.diameter_px * 0.5 * (sx + sy);
      int best = -1;
      double best_s = 1.0;
      for (std::size_t i = 0; i < fruits.size(); ++i) {
        const double s = (c - fruits[i].centre).norm() / (0.5 * fruits[i].diameter_px);
        if (s < best_s) best_s = s, best = static_cast<int>(i);
      }
      if (best < 0) {
        ++unmatched;
        continue;
      }
      on[static_cast<std::size_t>(best)].push_back({diameter, c.x()});
      const auto& t = fruits[static_cast<std::size_t>(best)];
      if (t.visible >= min_visible) {
        const int bin = static_cast<int>(std::floor(t.depth_m * 10));
        depth_err_bins[bin].push_back((f_mean * d_o / diameter - t.depth_m) * 1e3);
      }
    }
    const bool verbose = scored_frames <= verbose_frames;
    if (verbose) std::printf("frame %d (%zu detections)\n", index, det.fruits.size());
    for (std::size_t i = 0; i < fruits.size(); ++i) {
      const auto& t = fruits[i];
      if (verbose && t.visible >= 0.3) {
        std::printf("  fruit %2d vis %.2f depth %.3f m true %5.1f px:", t.id, t.visible, t.depth_m, t.diameter_px);
        for (const auto& [d, u] : on[i]) std::printf(" %5.1f (%+.0f%%)", d, 100 * (d / t.diameter_px - 1));
        std::printf("\n");
      }
      if (t.visible < min_visible) continue;
      ++histogram[static_cast<int>(on[i].size())];
      double largest = 0;
      for (const auto& [d, u] : on[i]) {
        largest = std::max(largest, d);
        diam_err_all.push_back(100 * (d / t.diameter_px - 1));
      }
      if (!on[i].empty()) {
        diam_err_best.push_back(100 * (largest / t.diameter_px - 1));
        depth_err_largest[static_cast<int>(std::floor(t.depth_m * 10))].push_back((f_mean * d_o / largest - t.depth_m) *
                                                                                  1e3);
      }
    }
    if (!overlay.empty()) {
      cv::Mat3b canvas;
      cv::resize(decoded.bgr, canvas, cv::Size(), 2 * sx, 2 * sy, cv::INTER_NEAREST);
      const double cs = static_cast<double>(canvas.cols) / 640.0;
      for (const auto& t : fruits) {
        const cv::Scalar col = t.visible >= min_visible ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 120, 0);
        cv::circle(canvas, cv::Point(cvRound(t.centre.x() * cs), cvRound(t.centre.y() * cs)),
                   cvRound(0.5 * t.diameter_px * cs), col, 1, cv::LINE_AA);
        cv::putText(canvas, std::to_string(t.id), cv::Point(cvRound(t.centre.x() * cs), cvRound(t.centre.y() * cs)),
                    cv::FONT_HERSHEY_SIMPLEX, 0.4, col, 1);
      }
      for (const auto& d : det.fruits) {
        const double u = ((d.u + 0.5) * sx + roi.x - 0.5) * cs, v = ((d.v + 0.5) * sy + roi.y - 0.5) * cs;
        cv::circle(canvas, cv::Point(cvRound(u), cvRound(v)), cvRound(0.5 * d.diameter_px * sx * cs),
                   cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
        cv::drawMarker(canvas, cv::Point(cvRound(u), cvRound(v)), cv::Scalar(255, 255, 0), cv::MARKER_CROSS, 6);
      }
      char name[64];
      std::snprintf(name, sizeof name, "/fixed_%05d.png", index);
      cv::imwrite(overlay + name, canvas);
      // The mask: pixels outside it darkened.
      cv::Mat1b mask;
      cv::resize(detector.mask(), mask, canvas.size(), 0, 0, cv::INTER_NEAREST);
      cv::Mat3b masked;
      cv::resize(decoded.bgr, masked, canvas.size(), 0, 0, cv::INTER_NEAREST);
      masked.setTo(cv::Scalar(60, 0, 60), ~mask);
      cv::imwrite(overlay + std::string(name).replace(1, 5, "mask_"), masked);
      if (crop.size() == 4) {
        const cv::Rect rc(cvRound(crop[0] * cs), cvRound(crop[1] * cs), cvRound(crop[2] * cs), cvRound(crop[3] * cs));
        cv::Mat both;
        cv::hconcat(canvas(rc), masked(rc), both);
        cv::resize(both, both, cv::Size(), 3, 3, cv::INTER_NEAREST);
        cv::imwrite(overlay + std::string(name).replace(1, 5, "crop_"), both);
      }
    }
  }

  int fruit_scored = 0;
  for (const auto& [n, k] : histogram) fruit_scored += k;
  std::printf("frames %d, fruit-frames with visible >= %.2f: %d\n", scored_frames, min_visible, fruit_scored);
  for (const auto& [n, k] : histogram)
    std::printf("  %d detection(s): %d (%.1f %%)\n", n, k, 100.0 * k / std::max(1, fruit_scored));
  auto abs_of = [](std::vector<double> v) {
    for (double& x : v) x = std::fabs(x);
    return v;
  };
  std::vector<double> sorted = abs_of(diam_err_best);
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted.empty() ? NAN : sorted[sorted.size() / 2];
  int within10 = 0;
  for (double x : sorted) within10 += x <= 10;
  std::printf(
      "largest detection per fruit: diameter error mean %+.1f %%, mean |err| %.1f %%, median |err| %.1f %%, "
      "within 10 %%: %d of %zu\n",
      mean(diam_err_best), mean(abs_of(diam_err_best)), median, within10, sorted.size());
  std::printf("every detection on such fruit: %zu, diameter error mean %+.1f %%, mean |err| %.1f %%\n",
              diam_err_all.size(), mean(diam_err_all), mean(abs_of(diam_err_all)));
  std::printf("depth f*D_o/d - true [mm] by true depth (every detection on such fruit):\n");
  for (const auto& [bin, v] : depth_err_bins)
    std::printf("  %4d-%4d mm: n %4zu mean %+6.0f rms %5.0f\n", bin * 100, bin * 100 + 100, v.size(), mean(v), rms(v));
  std::printf("the same, largest detection per fruit only:\n");
  for (const auto& [bin, v] : depth_err_largest)
    std::printf("  %4d-%4d mm: n %4zu mean %+6.0f rms %5.0f\n", bin * 100, bin * 100 + 100, v.size(), mean(v), rms(v));
  std::printf("detections %d, not on any fruit %d; detector %.2f ms per frame\n", detections_total, unmatched,
              detect_ms / std::max(1, scored_frames));
  return 0;
}
