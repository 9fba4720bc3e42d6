// The field look's shading pass (after the geometry pass has left the nearest
// surface per pixel) and the image motion that blurs it; renderer.hpp.
#include <algorithm>
#include <cmath>

#include "sim/renderer.hpp"

namespace harvest::sim {
namespace {

const Vec3f kUpBase(-1.0f, 0.0f, 0.0f);  // the thesis base frame's x axis points down

}  // namespace

void Renderer::shade_field(const Scene& scene, const Placement& pose, const Eigen::Vector3f& sun) {
  const Lighting& light = scene.lighting();
  shadows_.update(scene);
  const Eigen::Matrix3f r = pose.rotation.cast<float>();  // camera -> base
  const Vec3f pos = pose.position.cast<float>();
  const Mat3 rt = pose.rotation.transpose();
  const Vec3 t = -rt * pose.position;
  const Vec3f sun_base = light.sun_direction.cast<float>();

  struct FruitView {
    Vec3f c;
    float r;
    FruitMaterial m;
  };
  std::vector<FruitView> fruit;
  fruit.reserve(scene.fruit().size());
  for (std::size_t k = 0; k < scene.fruit().size(); ++k) {
    const Fruit& f = scene.fruit()[k];
    fruit.push_back({(rt * f.position + t).cast<float>(), static_cast<float>(f.radius), fruit_material(scene, k)});
  }
  struct LeafView {
    Vec3f c, n, u, v;
    float hl, hw;
  };
  std::vector<LeafView> leaves;
  std::vector<LeafMaterial> leaf_mats;
  leaves.reserve(scene.leaves().size());
  leaf_mats.reserve(scene.leaves().size());
  for (std::size_t k = 0; k < scene.leaves().size(); ++k) {
    const Leaf& l = scene.leaves()[k];
    leaves.push_back({(rt * l.centre + t).cast<float>(), (rt * l.normal).cast<float>(), (rt * l.u).cast<float>(),
                      (rt * l.v).cast<float>(), static_cast<float>(l.half_length),
                      static_cast<float>(l.half_width)});
    leaf_mats.push_back(leaf_material(look_, k, l.albedo_rgb));
  }

  const ShadowMap::View shadow = shadows_.view(r, pos);
  const float exposure = static_cast<float>(light.exposure);
  const std::size_t n = ids_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t id = ids_[i];
    const Vec3f d(nx_[i], ny_[i], 1.0f);
    Vec3f c;
    if (id == kSky) {
      c = background((r * d).normalized(), kUpBase, light);
    } else {
      const Vec3f p = depth_[i] * d;
      const Vec3f view = -d.normalized();
      const int32_t k = prim_[i];
      if (id >= 0) {
        const bool inside = k < 0;
        const FruitView& f = fruit[static_cast<std::size_t>(inside ? -1 - k : k)];
        if (inside) {
          c = f.m.orange * static_cast<float>(light.ambient * 0.3);
        } else {
          const Vec3f nrm = (p - f.c) / f.r;
          const Vec3f n_base = r * nrm;
          const float cos_sun = nrm.dot(sun);
          const float lit = cos_sun > 0.0f ? shadow.sunlit(p, cos_sun) : 0.0f;  // facing away: no sun anyway
          c = shade_fruit(f.m, f.r, nrm, n_base, view, sun, n_base.dot(kUpBase), light, lit);
        }
      } else if (id == kLeaf) {
        const LeafView& l = leaves[static_cast<std::size_t>(k)];
        const Vec3f q = p - l.c;
        const float su = q.dot(l.u), sv = q.dot(l.v);
        const float qu = su / l.hl;
        const float qv = sv / std::max(1e-6f, l.hw * (1.0f - qu * qu));
        const Vec3f face = l.n.dot(d) > 0.0f ? Vec3f(-l.n) : l.n;
        const float lit = shadow.sunlit(p, face.dot(sun));
        c = shade_leaf(leaf_mats[static_cast<std::size_t>(k)], qu, qv, su, sv, face, l.v, view, sun, light, lit);
      } else if (id == kBranch) {
        const Bead& b = scene.beads()[static_cast<std::size_t>(k)];
        const Vec3f p_base = r * p + pos;
        const Vec3f nrm = (p_base - b.centre.cast<float>()) / static_cast<float>(b.radius);
        const float lit = shadow.sunlit(p, nrm.dot(sun_base));
        c = shade_bark(r.transpose() * nrm, p_base, sun, nrm.dot(kUpBase), light, lit);
      } else {  // kExtra: lit like a leaf without texture
        const Vec3f nrm = extra_normal_[i].dot(d) > 0.0f ? Vec3f(-extra_normal_[i]) : extra_normal_[i];
        const float lit = shadow.sunlit(p, nrm.dot(sun));
        c = rgb_[i].cast<float>() *
            static_cast<float>(light.ambient + light.diffuse * std::max(0.0f, nrm.dot(sun)) * lit);
      }
    }
    c *= exposure;
    radiance_[3 * i] = c.x();
    radiance_[3 * i + 1] = c.y();
    radiance_[3 * i + 2] = c.z();
  }
}

Eigen::Vector2f Renderer::image_motion(const Placement& pose, const Placement& previous) const {
  if (!camera_ || look_.exposure_time_s <= 0.0) return Eigen::Vector2f::Zero();
  if ((pose.position - previous.position).norm() < 1e-9 && (pose.rotation - previous.rotation).norm() < 1e-9)
    return Eigen::Vector2f::Zero();
  // Depth of what the middle of the image sees (median of a sparse grid).
  std::vector<float> z;
  for (int y = h_ / 4; y < 3 * h_ / 4; y += 8)
    for (int x = w_ / 4; x < 3 * w_ / 4; x += 8) {
      const float v = depth_[static_cast<std::size_t>(y) * w_ + x];
      if (std::isfinite(v)) z.push_back(v);
    }
  double depth = 1.0;
  if (!z.empty()) {
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    depth = z[z.size() / 2];
  }
  // Where the point on the optical axis at that depth was one frame earlier.
  const Vec3 p_base = pose.rotation * Vec3(0, 0, depth) + pose.position;
  const Vec3 p_prev = previous.rotation.transpose() * (p_base - previous.position);
  if (p_prev.z() < 0.01) return Eigen::Vector2f::Zero();
  const double share = look_.exposure_time_s * rate_hz_;  // exposure time / frame period
  return Eigen::Vector2f(static_cast<float>(-model_.fx * p_prev.x() / p_prev.z() * share),
                         static_cast<float>(-model_.fy * p_prev.y() / p_prev.z() * share));
}

}  // namespace harvest::sim
