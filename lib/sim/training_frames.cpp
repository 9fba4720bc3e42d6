#include "sim/training_frames.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <stdexcept>

#include "sim/renderer.hpp"
#include "sim/scene.hpp"

namespace harvest::sim {
namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  Vec3 v(n(rng), n(rng), n(rng));
  return v.norm() > 1e-9 ? v.normalized() : Vec3::UnitX();
}

// Another day on another tree of the same kind: the scenario's looks drawn
// afresh. Base frame: -x is up, +y towards the tree (the fixed camera's
// optical axis), so the sun stays above the horizon, in front or behind.
Scenario varied(const Scenario& base, uint64_t seed, std::mt19937_64& rng) {
  Scenario s = base.with_seed(seed);
  s.look.style = "field";
  s.lighting.sun_direction =
      Vec3(uniform(rng, -0.9, -0.1), uniform(rng, -0.8, 0.5), uniform(rng, -0.6, 0.6)).normalized();
  s.lighting.ambient = uniform(rng, 0.3, 0.6);
  s.lighting.diffuse = uniform(rng, 0.4, 0.8);
  s.look.green_fraction = uniform(rng, 0.0, 0.25);
  s.look.half_ripe_fraction = uniform(rng, 0.0, 0.25);
  s.look.dry_leaf_fraction = uniform(rng, 0.02, 0.12);
  s.look.exposure_time_s = uniform(rng, 0.002, 0.012);
  s.look.white_balance_drift = uniform(rng, 0.02, 0.08);
  return s;
}

void write_image(const cv::Mat& bgr, const CameraSetup& cam, const std::filesystem::path& path) {
  const bool jpeg = cam.encoding == "jpeg";
  std::vector<int> params;
  if (jpeg) params = {cv::IMWRITE_JPEG_QUALITY, cam.jpeg_quality};
  if (!cv::imwrite(path.string(), bgr, params)) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

FrameBox sphere_box(const geometry::CameraModel& model, const Eigen::Vector3d& c, double r) {
  // The limb: the circle where the cone from the optical centre touches the
  // sphere, centred at c (1 - r^2/|c|^2) with radius r sqrt(1 - r^2/|c|^2).
  const double d2 = c.squaredNorm();
  const Eigen::Vector3d centre = c * (1.0 - r * r / d2);
  const double radius = r * std::sqrt(std::max(0.0, 1.0 - r * r / d2));
  const Eigen::Vector3d a = c.unitOrthogonal(), b = c.normalized().cross(a);
  FrameBox box{1e18, 1e18, -1e18, -1e18, 0};
  for (int k = 0; k < 32; ++k) {
    const double t = 2.0 * std::numbers::pi * k / 32;
    const Eigen::Vector2d px = model.project(centre + radius * (std::cos(t) * a + std::sin(t) * b));
    box.x1 = std::min(box.x1, px.x());
    box.y1 = std::min(box.y1, px.y());
    box.x2 = std::max(box.x2, px.x());
    box.y2 = std::max(box.y2, px.y());
  }
  return box;
}

std::vector<std::string> render_training_frames(const Scenario& scenario, const std::string& name,
                                                const TrainingFramesOptions& o, const std::filesystem::path& out_dir) {
  std::filesystem::create_directories(out_dir / "images");
  std::vector<std::string> rows;
  for (int k = 0; k < o.scenes; ++k) {
    const uint64_t seed = o.seed + static_cast<uint64_t>(k);
    std::mt19937_64 rng(seed * 7919 + 17);
    const Scenario sc = varied(scenario, seed, rng);
    const Scene scene(sc);

    // Renders `pose` (after the warm-up frames at `previous`) and writes the image and its boxes.
    auto shoot = [&](const CameraSetup& cam, Renderer& renderer, const Placement& pose, const Placement& previous,
                     const std::string& image) {
      for (int w = 0; w < o.warmup_frames; ++w) renderer.render(scene, previous, previous);
      const cv::Mat& bgr = renderer.render(scene, pose, previous);
      write_image(bgr, cam, out_dir / "images" / image);
      const auto& visible = renderer.visible_pixels();
      const auto& silhouette = renderer.silhouette_pixels();
      const auto& fruit = scene.fruit();
      for (std::size_t i = 0; i < fruit.size() && i < silhouette.size(); ++i) {
        if (fruit[i].state != FruitState::kOnTree || silhouette[i] <= 0) continue;
        const double share = static_cast<double>(visible[i]) / silhouette[i];
        const Vec3 p_cam = pose.rotation.transpose() * (fruit[i].position - pose.position);
        if (share < o.min_visible || p_cam.z() <= 1.5 * fruit[i].radius) continue;
        const FrameBox b = sphere_box(renderer.model(), p_cam, fruit[i].radius);
        char line[256];
        std::snprintf(line, sizeof line, "%s,%d,%d,%.1f,%.1f,%.1f,%.1f,%.3f", image.c_str(), bgr.cols, bgr.rows, b.x1,
                      b.y1, b.x2, b.y2, share);
        rows.emplace_back(line);
      }
    };
    const std::string stem = name + "_s" + std::to_string(seed);
    const char* ext = ".jpg";

    if (o.fixed_view) {
      Renderer fixed(sc.fixed_camera.model, sc.fixed_camera.noise_std, seed);
      fixed.set_look(sc.look, sc.fixed_camera.rate_hz);
      shoot(sc.fixed_camera, fixed, sc.fixed_camera_truth, sc.fixed_camera_truth, stem + "_fixed" + ext);
    }

    std::vector<std::size_t> on_tree;
    for (std::size_t i = 0; i < scene.fruit().size(); ++i)
      if (scene.fruit()[i].state == FruitState::kOnTree) on_tree.push_back(i);
    if (on_tree.empty()) continue;
    Renderer hand(sc.hand_camera.model, sc.hand_camera.noise_std, seed + 1);
    hand.set_look(sc.look, sc.hand_camera.rate_hz);
    for (int v = 0; v < o.hand_views; ++v) {
      const Vec3 fruit =
          scene.fruit()[on_tree[std::uniform_int_distribution<std::size_t>(0, on_tree.size() - 1)(rng)]].position;
      // From the side the arm comes from, within about 30 degrees; 0.1 to 0.9 m away (log-uniform: close views are
      // few seconds of a run but where the detector must hold).
      const Vec3 dir = ((sc.arm.start_tool_position - fruit).normalized() + 0.5 * random_unit(rng)).normalized();
      const double d = std::exp(uniform(rng, std::log(0.1), std::log(0.9)));
      const Vec3 at = fruit + d * dir;
      const Vec3 aim = fruit + 0.3 * d * Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
      const Mat3 rot = look_at_rotation(at, aim) *
                       Eigen::AngleAxisd(uniform(rng, -0.45, 0.45), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const double speed = uniform(rng, 0.0, o.max_speed);
      const Placement pose{rot, at}, before{rot, at + dir * speed / sc.hand_camera.rate_hz};
      shoot(sc.hand_camera, hand, pose, before, stem + "_hand" + std::to_string(v) + ext);
    }
  }
  return rows;
}

}  // namespace harvest::sim
