#include "sim/renderer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "sim/splitmix.hpp"

namespace harvest::sim {
namespace {

constexpr float kNear = 0.005f;  // [m] nothing closer to the lens is drawn
constexpr std::size_t kNoiseTable = 1 << 16;


double shade(const Lighting& light, double cos_sun) {
  return (light.ambient + light.diffuse * std::max(0.0, cos_sun)) * light.exposure;
}

}  // namespace

Renderer::Renderer(const geometry::CameraModel& model, double noise_std, uint64_t seed)
    : model_(model), w_(model.width), h_(model.height), noise_state_(seed), noise_std_(noise_std), seed_(seed) {
  model_.validate();
  const std::size_t n = static_cast<std::size_t>(w_) * h_;
  nx_.resize(n);
  ny_.resize(n);
  nx_min_ = ny_min_ = 1e9f;
  nx_max_ = ny_max_ = -1e9f;
  for (int y = 0; y < h_; ++y) {
    for (int x = 0; x < w_; ++x) {
      const Eigen::Vector2d m = model_.undistort_to_normalized(Eigen::Vector2d(x, y));
      const std::size_t i = static_cast<std::size_t>(y) * w_ + x;
      nx_[i] = static_cast<float>(m.x());
      ny_[i] = static_cast<float>(m.y());
      nx_min_ = std::min(nx_min_, nx_[i]);
      nx_max_ = std::max(nx_max_, nx_[i]);
      ny_min_ = std::min(ny_min_, ny_[i]);
      ny_max_ = std::max(ny_max_, ny_[i]);
    }
  }
  depth_.resize(n);
  ids_.resize(n);
  prim_.resize(n);
  rgb_.resize(n);
  image_.create(h_, w_, CV_8UC3);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise_std * 16.0);
  noise_.resize(kNoiseTable);
  for (auto& v : noise_) v = static_cast<int16_t>(std::clamp(gauss(rng), -32000.0, 32000.0));
}

Renderer::PixelBox Renderer::bounds(const Eigen::Vector3f& c, float r) const {
  const PixelBox all{0, 0, w_ - 1, h_ - 1};
  const PixelBox none{1, 1, 0, 0};
  if (c.z() + r < kNear) return none;
  if (c.z() - r <= kNear) return all;  // straddles the lens plane: test every pixel
  // Conservative range of x/z and y/z over the sphere's bounding cube.
  const float z0 = c.z() - r, z1 = c.z() + r;
  float ax = std::min((c.x() - r) / z0, (c.x() - r) / z1), bx = std::max((c.x() + r) / z0, (c.x() + r) / z1);
  float ay = std::min((c.y() - r) / z0, (c.y() - r) / z1), by = std::max((c.y() + r) / z0, (c.y() + r) / z1);
  if (bx < nx_min_ || ax > nx_max_ || by < ny_min_ || ay > ny_max_) return none;
  return normalized_box(ax, bx, ay, by);
}

Renderer::PixelBox Renderer::normalized_box(float ax, float bx, float ay, float by) const {
  const PixelBox none{1, 1, 0, 0};
  if (bx < nx_min_ || ax > nx_max_ || by < ny_min_ || ay > ny_max_) return none;
  // Distortion is only trusted inside the field of view: clamp, then map a
  // 3x3 grid of the normalised box to pixels and pad.
  ax = std::max(ax, nx_min_);
  bx = std::min(bx, nx_max_);
  ay = std::max(ay, ny_min_);
  by = std::min(by, ny_max_);
  double px0 = 1e9, px1 = -1e9, py0 = 1e9, py1 = -1e9;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector2d p =
          model_.normalized_to_pixel(Eigen::Vector2d(ax + (bx - ax) * 0.5 * i, ay + (by - ay) * 0.5 * j));
      px0 = std::min(px0, p.x());
      px1 = std::max(px1, p.x());
      py0 = std::min(py0, p.y());
      py1 = std::max(py1, p.y());
    }
  }
  constexpr double kPad = 3.0;
  return {std::max(0, static_cast<int>(std::floor(px0 - kPad))), std::max(0, static_cast<int>(std::floor(py0 - kPad))),
          std::min(w_ - 1, static_cast<int>(std::ceil(px1 + kPad))),
          std::min(h_ - 1, static_cast<int>(std::ceil(py1 + kPad)))};
}

Renderer::PixelBox Renderer::leaf_bounds(const Eigen::Vector3f& c, const Eigen::Vector3f& u, const Eigen::Vector3f& v,
                                         float hl, float hw) const {
  // The blade lies inside the rectangle c +- hl u +- hw v. Clip that quad to
  // the near plane (z >= kNear) and project the corners: a convex polygon in
  // front of the lens projects inside the box of its projected corners. Much
  // tighter than the bounding sphere, above all for leaves next to the lens.
  const std::array<Eigen::Vector3f, 4> quad{c + hl * u + hw * v, c - hl * u + hw * v, c - hl * u - hw * v,
                                            c + hl * u - hw * v};
  float ax = 1e30f, bx = -1e30f, ay = 1e30f, by = -1e30f;
  bool any = false;
  auto add = [&](const Eigen::Vector3f& p) {
    const float x = p.x() / p.z(), y = p.y() / p.z();
    ax = std::min(ax, x);
    bx = std::max(bx, x);
    ay = std::min(ay, y);
    by = std::max(by, y);
    any = true;
  };
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3f& p = quad[k];
    const Eigen::Vector3f& q = quad[(k + 1) % 4];
    const bool p_in = p.z() >= kNear, q_in = q.z() >= kNear;
    if (p_in) add(p);
    if (p_in != q_in) add(p + (q - p) * ((kNear - p.z()) / (q.z() - p.z())));  // edge crosses the near plane
  }
  if (!any) return {1, 1, 0, 0};
  return normalized_box(ax, bx, ay, by);
}

void Renderer::set_look(const Look& look, double rate_hz) {
  look_ = look;
  rate_hz_ = rate_hz;
  camera_.reset();
  last_pose_.reset();
  if (!look_.field()) return;
  std::vector<float> cos_field(nx_.size());
  for (std::size_t i = 0; i < nx_.size(); ++i) cos_field[i] = 1.0f / std::sqrt(1.0f + nx_[i] * nx_[i] + ny_[i] * ny_[i]);
  camera_.emplace(look_, std::move(cos_field), w_, h_, rate_hz, noise_std_, seed_);
  radiance_.resize(3 * nx_.size());
}

FruitMaterial Renderer::fruit_material(const Scene& scene, std::size_t fruit_index) const {
  const Fruit& f = scene.fruit()[fruit_index];
  return sim::fruit_material(look_, f.id, f.albedo_rgb);
}

void Renderer::put(int i, float depth, const Vec3& rgb, int32_t id, int32_t prim) {
  if (depth >= depth_[i]) return;
  depth_[i] = depth;
  rgb_[i] = rgb;
  ids_[i] = id;
  prim_[i] = prim;
}

void Renderer::put_surface(int i, float depth, int32_t id, int32_t prim) {
  if (depth >= depth_[i]) return;
  depth_[i] = depth;
  ids_[i] = id;
  prim_[i] = prim;
}

void Renderer::Canvas::put(int i, float depth, const Vec3& albedo_rgb, const Eigen::Vector3f& normal) {
  if (depth < kNear || depth >= r_.depth_[i]) return;
  r_.put(i, depth, albedo_rgb, kExtra, -1);
  r_.extra_normal_[static_cast<std::size_t>(i)] = normal;
}

void Renderer::draw_sphere(const Eigen::Vector3f& c, float r, const Vec3& albedo, int32_t id, int32_t prim,
                           const Eigen::Vector3f& sun, const Lighting& light) {
  const PixelBox b = bounds(c, r);
  const float cc = c.squaredNorm() - r * r;
  for (int y = b.y0; y <= b.y1; ++y) {
    for (int x = b.x0; x <= b.x1; ++x) {
      const int i = y * w_ + x;
      const Eigen::Vector3f d(nx_[i], ny_[i], 1.0f);
      const float a = d.squaredNorm(), half_b = d.dot(c);
      const float disc = half_b * half_b - a * cc;
      if (disc < 0.0f) continue;
      const float s = std::sqrt(disc);
      float t = (half_b - s) / a;  // depth along the optical axis, since d.z = 1
      bool inside = false;
      if (t < kNear) {
        t = (half_b + s) / a;  // the lens is inside the sphere: we see its inner wall
        inside = true;
        if (t < kNear) continue;
      }
      if (id >= 0) ++silhouette_[static_cast<std::size_t>(id)];
      const int32_t p = inside ? -1 - prim : prim;
      if (camera_) {  // field look: shaded afterwards, only where nearest
        put_surface(i, t, id, p);
        continue;
      }
      const Eigen::Vector3f normal = (t * d - c) / r;
      const double lit = inside ? light.ambient * 0.3 : shade(light, normal.dot(sun));
      put(i, t, albedo * lit, id, p);
    }
  }
}

void Renderer::draw_leaf(const Leaf& leaf, int32_t prim, const Mat3& rt, const Vec3& t, const Eigen::Vector3f& sun,
                         const Lighting& light) {
  const Eigen::Vector3f c = (rt * leaf.centre + t).cast<float>();
  const Eigen::Vector3f n = (rt * leaf.normal).cast<float>();
  const Eigen::Vector3f u = (rt * leaf.u).cast<float>();
  const Eigen::Vector3f v = (rt * leaf.v).cast<float>();
  const float hl = static_cast<float>(leaf.half_length), hw = static_cast<float>(leaf.half_width);
  const PixelBox b = leaf_bounds(c, u, v, hl, hw);
  const float nc = n.dot(c);
  // Both faces of a blade catch light; the lit side is brighter.
  const Vec3 colour = leaf.albedo_rgb * shade(light, std::abs(n.dot(sun)));
  for (int y = b.y0; y <= b.y1; ++y) {
    for (int x = b.x0; x <= b.x1; ++x) {
      const int i = y * w_ + x;
      const Eigen::Vector3f d(nx_[i], ny_[i], 1.0f);
      const float nd = n.dot(d);
      if (std::abs(nd) < 1e-7f) continue;
      const float depth = nc / nd;
      if (depth < kNear || depth >= depth_[i]) continue;
      const Eigen::Vector3f q = depth * d - c;
      const float qu = q.dot(u) / hl;
      if (qu < -1.0f || qu > 1.0f) continue;
      if (std::abs(q.dot(v)) > hw * (1.0f - qu * qu)) continue;
      if (camera_)
        put_surface(i, depth, kLeaf, prim);
      else
        put(i, depth, colour, kLeaf, prim);
    }
  }
}

const cv::Mat& Renderer::render(const Scene& scene, const Placement& pose) {
  return render(scene, pose, last_pose_ ? *last_pose_ : pose);
}

const cv::Mat& Renderer::render(const Scene& scene, const Placement& pose, const Placement& previous) {
  const Lighting& light = scene.lighting();
  const Mat3 rt = pose.rotation.transpose();  // base -> camera (the rotation is orthogonal)
  const Vec3 t = -rt * pose.position;
  const Eigen::Vector3f sun = (rt * light.sun_direction).cast<float>();
  const Vec3 sky(light.sky_rgb[0], light.sky_rgb[1], light.sky_rgb[2]);

  std::fill(depth_.begin(), depth_.end(), std::numeric_limits<float>::infinity());
  std::fill(ids_.begin(), ids_.end(), kSky);
  std::fill(rgb_.begin(), rgb_.end(), sky * light.exposure);
  visible_.assign(scene.fruit().size(), 0);
  silhouette_.assign(scene.fruit().size(), 0);

  const Vec3 bark(96, 84, 68);
  const auto& beads = scene.beads();
  const auto& leaves = scene.leaves();
  const auto& fruit = scene.fruit();
  auto draw_beads = [&] {
    for (std::size_t k = 0; k < beads.size(); ++k)
      draw_sphere((rt * beads[k].centre + t).cast<float>(), static_cast<float>(beads[k].radius), bark, kBranch,
                  static_cast<int32_t>(k), sun, light);
  };
  auto draw_fruit = [&] {
    for (std::size_t k = 0; k < fruit.size(); ++k) {
      const Fruit& f = fruit[k];
      if (f.state == FruitState::kPicked || f.state == FruitState::kKnocked) continue;
      draw_sphere((rt * f.position + t).cast<float>(), static_cast<float>(f.radius), f.albedo_rgb, f.id,
                  static_cast<int32_t>(k), sun, light);
    }
  };
  if (camera_) {
    // Field look: nothing is shaded while drawing, so draw near to far and let
    // the depth test turn most of what lies behind away early.
    draw_fruit();
    leaf_order_.resize(leaves.size());
    for (std::size_t k = 0; k < leaves.size(); ++k)
      leaf_order_[k] = {static_cast<float>((rt * leaves[k].centre + t).z() - leaves[k].half_length),
                        static_cast<int32_t>(k)};
    std::sort(leaf_order_.begin(), leaf_order_.end());
    for (const auto& [z, k] : leaf_order_) draw_leaf(leaves[static_cast<std::size_t>(k)], k, rt, t, sun, light);
    draw_beads();
  } else {
    draw_beads();
    for (std::size_t k = 0; k < leaves.size(); ++k) draw_leaf(leaves[k], static_cast<int32_t>(k), rt, t, sun, light);
    draw_fruit();
  }
  if (!extras_.empty()) {
    extra_normal_.resize(ids_.size());
    Canvas canvas(*this);
    for (const auto& e : extras_) e->draw(canvas, rt, t);
  }
  for (const int32_t id : ids_)
    if (id >= 0) ++visible_[static_cast<std::size_t>(id)];

  if (camera_) {
    shade_field(scene, pose, sun);
    camera_->develop(radiance_, image_motion(pose, previous), image_);
  } else {
    write_flat(sun, light);
  }
  last_pose_ = pose;
  return image_;
}

void Renderer::write_flat(const Eigen::Vector3f& sun, const Lighting& light) {
  // Write out with sensor noise; the table offset advances every frame.
  const uint64_t offset = splitmix_next(noise_state_);
  const std::size_t n = ids_.size();
  for (std::size_t i = 0; i < n; ++i) {
    auto* px = image_.ptr<uint8_t>(0) + 3 * i;
    const Vec3 c = ids_[i] == kExtra ? Vec3(rgb_[i] * shade(light, std::abs(extra_normal_[i].dot(sun)))) : rgb_[i];
    for (int ch = 0; ch < 3; ++ch) {
      const int16_t e = noise_[(offset + 3 * i + static_cast<std::size_t>(ch)) & (kNoiseTable - 1)];
      const double value = c[2 - ch] + e / 16.0;  // BGR order
      px[ch] = static_cast<uint8_t>(std::clamp(value + 0.5, 0.0, 255.0));
    }
  }
}

}  // namespace harvest::sim
