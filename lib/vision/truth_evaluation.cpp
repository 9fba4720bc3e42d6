#include "vision/truth_evaluation.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <ostream>

#include "camera/image_codec.hpp"
#include "harvest/image_t.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/overlay.hpp"

namespace harvest::vision {

namespace {

// printf onto a stream (the tool's report is a table of fixed-width numbers).
[[gnu::format(printf, 2, 3)]] void print(std::ostream& out, const char* format, ...) {
  char buf[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  out << buf;
}

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

std::vector<double> abs_of(std::vector<double> v) {
  for (double& x : v) x = std::fabs(x);
  return v;
}

}  // namespace

std::vector<TruthFruit> project_truth(const sim_truth_t& truth, const geometry::CameraModel& camera,
                                      const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position,
                                      bool every_fruit_visible) {
  std::vector<TruthFruit> fruits;
  for (const auto& f : truth.fruits) {
    if (f.state != sim_fruit_truth_t::ON_TREE) continue;
    const Eigen::Vector3d p =
        rotation.transpose() * (Eigen::Vector3d(f.position_base[0], f.position_base[1], f.position_base[2]) - position);
    if (p.z() < 0.1) continue;
    // The limb circle: centre c, radius rho, in the plane normal to p.
    const double rr = 0.5 * f.diameter_m, d2 = p.squaredNorm();
    const Eigen::Vector3d c = p * (1 - rr * rr / d2);
    const double rho = rr * std::sqrt(1 - rr * rr / d2);
    const Eigen::Vector3d a = p.cross(Eigen::Vector3d::UnitY()).normalized(), b = p.cross(a).normalized();
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (int k = 0; k < 72; ++k) {
      const double t = k * 2 * M_PI / 72;
      const Eigen::Vector2d q = camera.project(c + rho * (std::cos(t) * a + std::sin(t) * b));
      x0 = std::min(x0, q.x()), x1 = std::max(x1, q.x()), y0 = std::min(y0, q.y()), y1 = std::max(y1, q.y());
    }
    TruthFruit t;
    t.centre = camera.project(p);
    t.diameter_px = 0.5 * ((x1 - x0) + (y1 - y0));
    t.depth_m = p.z();
    t.visible = every_fruit_visible ? 1.0f : f.visible_fraction_fixed;
    t.id = f.sim_id;
    if (t.centre.x() < -t.diameter_px || t.centre.y() < -t.diameter_px || t.centre.x() > camera.width + t.diameter_px ||
        t.centre.y() > camera.height + t.diameter_px)
      continue;
    fruits.push_back(t);
  }
  return fruits;
}

int fruit_of(const SensorDetection& d, const std::vector<TruthFruit>& fruits) {
  int best = -1;
  double best_s = 1.0;
  for (std::size_t i = 0; i < fruits.size(); ++i) {
    const double s = (d.centre - fruits[i].centre).norm() / (0.5 * fruits[i].diameter_px);
    if (s < best_s) best_s = s, best = static_cast<int>(i);
  }
  return best;
}

TruthEvaluation::TruthEvaluation(double min_visible, double f_mean, double d_o)
    : min_visible_(min_visible), f_mean_(f_mean), d_o_(d_o) {}

std::vector<std::vector<double>> TruthEvaluation::add_frame(const std::vector<SensorDetection>& detections,
                                                            const std::vector<TruthFruit>& fruits) {
  std::vector<std::vector<double>> on(fruits.size());      // diameters per fruit
  std::vector<std::vector<double>> offset(fruits.size());  // their centres' distance from the true one [px]
  for (const auto& d : detections) {
    ++detections_total_;
    const int best = fruit_of(d, fruits);
    if (best < 0) {
      ++unmatched_;
      continue;
    }
    on[static_cast<std::size_t>(best)].push_back(d.diameter_px);
    const auto& t = fruits[static_cast<std::size_t>(best)];
    offset[static_cast<std::size_t>(best)].push_back((d.centre - t.centre).norm());
    if (t.visible >= min_visible_) {
      const int bin = static_cast<int>(std::floor(t.depth_m * 10));
      depth_err_bins_[bin].push_back((f_mean_ * d_o_ / d.diameter_px - t.depth_m) * 1e3);
    }
  }
  for (std::size_t i = 0; i < fruits.size(); ++i) {
    const auto& t = fruits[i];
    if (t.visible < min_visible_) continue;
    ++histogram_[static_cast<int>(on[i].size())];
    double largest = 0, largest_offset = 0;
    for (std::size_t k = 0; k < on[i].size(); ++k) {
      const double d = on[i][k];
      if (d > largest) largest = d, largest_offset = offset[i][k];
      diam_err_all_.push_back(100 * (d / t.diameter_px - 1));
    }
    if (!on[i].empty()) {
      diam_err_best_.push_back(100 * (largest / t.diameter_px - 1));
      centre_err_largest_[static_cast<int>(std::floor(t.depth_m * 10))].push_back(100 * largest_offset / t.diameter_px);
      depth_err_largest_[static_cast<int>(std::floor(t.depth_m * 10))].push_back(
          (f_mean_ * d_o_ / largest - t.depth_m) * 1e3);
    }
  }
  return on;
}

int TruthEvaluation::fruit_scored() const {
  int n = 0;
  for (const auto& [detections, fruit] : histogram_) n += fruit;
  return n;
}

void TruthEvaluation::report(std::ostream& out, int scored_frames, double detect_ms) const {
  const int scored = fruit_scored();
  print(out, "frames %d, fruit-frames with visible >= %.2f: %d\n", scored_frames, min_visible_, scored);
  for (const auto& [n, k] : histogram_)
    print(out, "  %d detection(s): %d (%.1f %%)\n", n, k, 100.0 * k / std::max(1, scored));
  std::vector<double> sorted = abs_of(diam_err_best_);
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted.empty() ? NAN : sorted[sorted.size() / 2];
  int within10 = 0;
  for (double x : sorted) within10 += x <= 10;
  print(out,
        "largest detection per fruit: diameter error mean %+.1f %%, mean |err| %.1f %%, median |err| %.1f %%, "
        "within 10 %%: %d of %zu\n",
        mean(diam_err_best_), mean(abs_of(diam_err_best_)), median, within10, sorted.size());
  print(out, "every detection on such fruit: %zu, diameter error mean %+.1f %%, mean |err| %.1f %%\n",
        diam_err_all_.size(), mean(diam_err_all_), mean(abs_of(diam_err_all_)));
  print(out, "depth f*D_o/d - true [mm] by true depth (every detection on such fruit):\n");
  for (const auto& [bin, v] : depth_err_bins_)
    print(out, "  %4d-%4d mm: n %4zu mean %+6.0f rms %5.0f\n", bin * 100, bin * 100 + 100, v.size(), mean(v), rms(v));
  print(out, "the same, largest detection per fruit only:\n");
  for (const auto& [bin, v] : depth_err_largest_)
    print(out, "  %4d-%4d mm: n %4zu mean %+6.0f rms %5.0f\n", bin * 100, bin * 100 + 100, v.size(), mean(v), rms(v));
  print(out, "centre of the largest detection per fruit from the true centre [%% of the true diameter]:\n");
  for (const auto& [bin, v] : centre_err_largest_)
    print(out, "  %4d-%4d mm: n %4zu mean %5.1f rms %5.1f max %5.1f\n", bin * 100, bin * 100 + 100, v.size(), mean(v),
          rms(v), *std::max_element(v.begin(), v.end()));
  print(out, "detections %d, not on any fruit %d; detector %.2f ms per frame\n", detections_total_, unmatched_,
        detect_ms / std::max(1, scored_frames));
}

int run_truth_evaluation(const std::vector<rt::LogRecord>& log, const DetectorNodeConfig& config,
                         const TrueCamera& truth_camera, const TruthEvalOptions& options, std::ostream& out,
                         std::ostream& err) {
  FruitDetector detector(config.detector, config.calibration.fx, config.calibration.fy);
  const bool hand = options.camera == "hand";
  const double f_mean = 0.5 * (config.calibration.fx + config.calibration.fy);
  TruthEvaluation eval(options.min_visible, f_mean, config.detector.fruit_diameter_m);
  Eigen::Matrix3d rot = truth_camera.rotation;
  Eigen::Vector3d pos = truth_camera.position;
  std::optional<sim_truth_t> truth;
  int index = -1, scored_frames = 0, rc = 0;
  double detect_ms = 0;

  for (const auto& r : log) {
    if (r.channel == "SIM_TRUTH") {
      truth = rt::decode<sim_truth_t>(r.data);
      continue;
    }
    if (r.channel != (hand ? "CAMERA_HAND" : "CAMERA_FIXED")) continue;
    ++index;
    if (index < options.first || (index - options.first) % options.every != 0 || !truth) continue;
    if (scored_frames >= options.count) break;
    const auto img = rt::decode<image_t>(r.data);
    if (!img) continue;
    const auto decoded = camera::decode_image(*img);
    if (!decoded.ok()) continue;
    const cv::Rect2d roi = camera::image_roi(*img);
    const double sx = roi.width / decoded.bgr.cols, sy = roi.height / decoded.bgr.rows;
    // Wall time of the detector alone: a figure for the report, not part of any result.
    const auto t0 = std::chrono::steady_clock::now();
    const auto det = detector.detect(decoded.bgr);
    detect_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ++scored_frames;

    if (hand) {
      const auto& o = truth->hand_camera_pose.orientation;
      rot = Eigen::Quaterniond(o[0], o[1], o[2], o[3]).normalized().toRotationMatrix();
      pos = Eigen::Vector3d(truth->hand_camera_pose.position[0], truth->hand_camera_pose.position[1],
                            truth->hand_camera_pose.position[2]);
    }
    const std::vector<TruthFruit> fruits = project_truth(*truth, truth_camera.model, rot, pos, hand);
    std::vector<SensorDetection> sensor;
    for (const auto& d : det.fruits)
      sensor.push_back({Eigen::Vector2d((d.u + 0.5) * sx + roi.x - 0.5, (d.v + 0.5) * sy + roi.y - 0.5),
                        d.diameter_px * 0.5 * (sx + sy)});
    const auto on = eval.add_frame(sensor, fruits);

    if (scored_frames <= options.verbose_frames) {
      print(out, "frame %d (%zu detections)\n", index, det.fruits.size());
      for (std::size_t i = 0; i < fruits.size(); ++i) {
        const auto& t = fruits[i];
        if (t.visible < 0.3) continue;
        print(out, "  fruit %2d vis %.2f depth %.3f m true %5.1f px:", t.id, t.visible, t.depth_m, t.diameter_px);
        for (const auto& d : sensor)  // each detection on the fruit: diameter, its error, centre offset [px]
          if (fruit_of(d, fruits) == static_cast<int>(i))
            print(out, " %5.1f (%+.0f%%) at %.0f px", d.diameter_px, 100 * (d.diameter_px / t.diameter_px - 1),
                  (d.centre - t.centre).norm());
        out << "\n";
      }
    }
    if (!options.overlay_dir.empty()) {
      std::string error;
      if (!write_truth_overlays(options.overlay_dir, index, decoded.bgr, detector.mask(), roi, det, fruits,
                                truth_camera.model.width, options.min_visible, options.crop, error)) {
        err << "harvest-vision-eval: " << error << "\n";
        rc = 1;
      }
    }
  }
  eval.report(out, scored_frames, detect_ms);
  return rc;
}

}  // namespace harvest::vision
