#include "sim/materials.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "sim/splitmix.hpp"

namespace harvest::sim {
namespace {

float pow16(float x) {
  x *= x;
  x *= x;
  x *= x;
  return x * x;
}

// Texture coordinates on a sphere from its base-frame normal: the two
// components other than the largest (a cube map without the seams mattering
// for noise), each face shifted so faces do not repeat each other.
void cube_coords(const Vec3f& n, float& a, float& b) {
  const float ax = std::abs(n.x()), ay = std::abs(n.y()), az = std::abs(n.z());
  if (ax >= ay && ax >= az) {
    a = n.y() + (n.x() > 0 ? 11.0f : 23.0f), b = n.z();
  } else if (ay >= az) {
    a = n.x() + (n.y() > 0 ? 37.0f : 51.0f), b = n.z();
  } else {
    a = n.x() + (n.z() > 0 ? 67.0f : 83.0f), b = n.y();
  }
}

}  // namespace

NoiseTexture::NoiseTexture(int shift, uint64_t seed)
    : shift_(shift), mask_((1 << shift) - 1), t_(static_cast<std::size_t>(1) << (2 * shift), 0.0f) {
  const int size = 1 << shift;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  float weight = 0.5f;
  for (int period = size / 8; period >= 2; period /= 2, weight *= 0.55f) {
    const int cells = size / period;
    std::vector<float> lattice(static_cast<std::size_t>(cells * cells));
    for (auto& v : lattice) v = u(rng);
    const auto at = [&](int i, int j) {
      return lattice[static_cast<std::size_t>(((j % cells) * cells) + (i % cells))];
    };
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const int cx = x / period, cy = y / period;
        float fx = static_cast<float>(x % period) / period, fy = static_cast<float>(y % period) / period;
        fx = fx * fx * (3 - 2 * fx);
        fy = fy * fy * (3 - 2 * fy);
        const float top = at(cx, cy) + (at(cx + 1, cy) - at(cx, cy)) * fx;
        const float bottom = at(cx, cy + 1) + (at(cx + 1, cy + 1) - at(cx, cy + 1)) * fx;
        t_[static_cast<std::size_t>(y * size + x)] += weight * (top + (bottom - top) * fy);
      }
    }
  }
  // Stretch to [0, 1].
  const auto [lo, hi] = std::minmax_element(t_.begin(), t_.end());
  const float a = *lo, s = 1.0f / (*hi - *lo);
  for (auto& v : t_) v = (v - a) * s;
}

const NoiseTexture& NoiseTexture::get() {
  static const NoiseTexture texture(8, 0x5eed);
  return texture;
}

const NoiseTexture& NoiseTexture::fine() {
  static const NoiseTexture texture(6, 0xd1b);
  return texture;
}

double hashed_unit(uint64_t seed, uint64_t kind, uint64_t index) {
  const uint64_t h = splitmix_hash(splitmix_hash(splitmix_hash(seed) ^ kind) ^ index);
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

FruitMaterial fruit_material(const Look& look, int fruit_id, const Vec3& albedo) {
  FruitMaterial m;
  const auto id = static_cast<uint64_t>(fruit_id);
  const double r = hashed_unit(look.seed, 1, id);
  // Ripe oranges vary from yellow-orange to deep orange; the scene's colour
  // (which the thesis thresholds accept) is the middle of that spread.
  const double hue = hashed_unit(look.seed, 2, id) - 0.5;  // -0.5 .. 0.5
  // A sunlit ripe orange in a photograph is close to saturated (about RGB
  // 250, 140, 20); the flat look's colours are duller.
  m.orange = Vec3f(static_cast<float>(albedo.x() * 1.12 * (1.0 + 0.06 * hue)),
                   static_cast<float>(albedo.y() * 1.05 * (1.0 + 0.22 * hue)), static_cast<float>(albedo.z() * 0.6));
  const double g = hashed_unit(look.seed, 3, id);
  m.green = Vec3f(static_cast<float>(80 + 40 * g), static_cast<float>(122 + 30 * g), static_cast<float>(38 + 20 * g));
  m.texture_offset = static_cast<float>(hashed_unit(look.seed, 4, id) * 256.0);
  if (r < look.green_fraction) {
    m.ripeness = Ripeness::kGreen;
    m.green_share = 2.0f;  // everywhere
  } else if (r < look.green_fraction + look.half_ripe_fraction) {
    m.ripeness = Ripeness::kHalfRipe;
    m.green_share = static_cast<float>(0.3 + 0.35 * hashed_unit(look.seed, 5, id));
  }
  return m;
}

LeafMaterial leaf_material(const Look& look, std::size_t leaf_index, const Vec3& albedo) {
  LeafMaterial m;
  const auto i = static_cast<uint64_t>(leaf_index);
  m.texture_offset = static_cast<float>(hashed_unit(look.seed, 11, i) * 256.0);
  if (hashed_unit(look.seed, 12, i) < look.dry_leaf_fraction) {
    static const Vec3f dry[] = {Vec3f(122, 92, 52), Vec3f(156, 124, 70), Vec3f(98, 78, 52), Vec3f(140, 112, 58)};
    m.albedo = dry[static_cast<std::size_t>(hashed_unit(look.seed, 13, i) * 4.0) & 3u] *
               static_cast<float>(0.85 + 0.3 * hashed_unit(look.seed, 14, i));
    m.dry = true;
  } else {
    m.albedo = albedo.cast<float>();
  }
  return m;
}

Vec3f shade_fruit(const FruitMaterial& m, float radius_m, const Vec3f& n, const Vec3f& n_base, const Vec3f& view,
                  const Vec3f& sun, float up_dot, const Lighting& light, float sunlit) {
  const NoiseTexture& tex = NoiseTexture::get();
  float a, b;
  cube_coords(n_base, a, b);
  // Dimples (oil glands) about 3 mm apart: the fine texture's coarsest
  // octave (8 texels) at 0.4 mm a texel.
  const float k = radius_m / 0.0004f;
  const float dimple = NoiseTexture::fine().sample(a * k + m.texture_offset, b * k);
  Vec3f albedo = m.orange;
  if (m.green_share > 0.0f) {
    const float patch = tex.sample(a * 24.0f + m.texture_offset, b * 24.0f + 91.0f);
    const float g = std::clamp((m.green_share - patch) * 4.0f + 0.5f, 0.0f, 1.0f);
    albedo += (m.green - m.orange) * g;
  }
  if (up_dot > 0.988f) albedo = Vec3f(85, 90, 45);  // stem scar
  const float ambient = static_cast<float>(light.ambient) * (0.75f + 0.25f * up_dot);
  const float lambert = std::max(0.0f, n.dot(sun)) * static_cast<float>(light.diffuse) * sunlit;
  Vec3f c = albedo * ((ambient + lambert) * (0.9f + 0.2f * dimple));
  const Vec3f h = (sun + view).normalized();
  const float nh = std::max(0.0f, n.dot(h));
  const float nh16 = pow16(nh);
  const float spec = nh16 * nh16 * static_cast<float>(light.diffuse) * sunlit * (0.3f + 0.9f * dimple);
  return c + Vec3f(255, 248, 235) * spec;
}

Vec3f shade_leaf(const LeafMaterial& m, float qu, float qv, float s_m, float t_m, const Vec3f& n_face,
                 const Vec3f& across, const Vec3f& view, const Vec3f& sun, const Lighting& light, float sunlit) {
  const NoiseTexture& tex = NoiseTexture::get();
  const float aqv = std::abs(qv);
  Vec3f albedo = m.albedo * (0.86f + 0.28f * tex.sample(s_m * 500.0f + m.texture_offset, t_m * 500.0f));
  if (aqv < 0.07f) {
    albedo = m.dry ? albedo * 0.8f : Vec3f(albedo * 1.15f + Vec3f(14, 16, 0));  // midrib
  } else {
    const float ph = qu * 6.0f + aqv * 2.2f + m.texture_offset;
    if (ph - std::floor(ph) < 0.06f) albedo *= 1.08f;  // lateral veins
  }
  if (aqv > 0.92f) albedo *= 0.88f;  // rim
  // The blade is folded along its midrib: the normal leans across.
  const Vec3f n = (n_face - 0.35f * qv * across).normalized();
  const float ambient = static_cast<float>(light.ambient) * 0.85f;
  const float cs = n_face.dot(sun);
  Vec3f c = albedo * ambient;
  if (cs > 0.0f) {
    c += albedo * (std::max(0.0f, n.dot(sun)) * static_cast<float>(light.diffuse) * sunlit);
    if (!m.dry) {
      const float nh = std::max(0.0f, n.dot((sun + view).normalized()));
      c += Vec3f(235, 245, 235) * (0.3f * pow16(nh) * static_cast<float>(light.diffuse) * sunlit);  // wax
    }
  } else {
    // Sun behind the blade: light through it, yellow-green.
    const float through = (m.dry ? 0.08f : 0.32f) * -cs * static_cast<float>(light.diffuse) * sunlit;
    c += albedo.cwiseProduct(Vec3f(1.05f, 1.3f, 0.55f)) * through;
  }
  return c;
}

Vec3f shade_bark(const Vec3f& n, const Vec3f& p_base, const Vec3f& sun, float up_dot, const Lighting& light,
                 float sunlit) {
  const NoiseTexture& tex = NoiseTexture::get();
  const float t = tex.sample(p_base.y() * 350.0f + p_base.x() * 60.0f, (p_base.x() + p_base.z()) * 90.0f);
  const Vec3f albedo = Vec3f(104, 92, 76) * (0.55f + 0.8f * t);
  const float ambient = static_cast<float>(light.ambient) * (0.75f + 0.25f * up_dot);
  const float lambert = std::max(0.0f, n.dot(sun)) * static_cast<float>(light.diffuse) * sunlit;
  return albedo * (ambient + lambert);
}

Vec3f background(const Vec3f& d, const Vec3f& up, const Lighting& light) {
  const NoiseTexture& tex = NoiseTexture::get();
  const float e = d.dot(up);
  const float ridge = 0.03f + 0.12f * (tex.sample(d.y() * 40.0f + d.z() * 23.0f, 17.0f) - 0.5f);
  if (e > ridge) {
    // Open sky, brighter than anything lit: a camera exposed for the canopy clips it.
    const Vec3f sky(static_cast<float>(light.sky_rgb[0]), static_cast<float>(light.sky_rgb[1]),
                    static_cast<float>(light.sky_rgb[2]));
    const float haze = tex.sample(d.y() * 25.0f + 3.0f, d.z() * 25.0f + d.x() * 25.0f);
    return sky * (1.5f + 0.3f * e + 0.25f * haze);
  }
  // Other rows of trees, darker towards the ground.
  const float t = tex.sample(d.y() * 160.0f + d.x() * 90.0f, d.z() * 160.0f + d.x() * 40.0f);
  const float ground = std::clamp(-e * 2.0f, 0.0f, 1.0f);
  const Vec3f trees = Vec3f(42, 62, 32) * (0.5f + 1.0f * t);
  const Vec3f soil = Vec3f(104, 92, 70) * (0.6f + 0.6f * t);
  return trees + (soil - trees) * ground;
}

}  // namespace harvest::sim
