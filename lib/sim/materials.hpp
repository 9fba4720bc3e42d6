// Surfaces of the "field" look (scenario `look.style: field`): procedural
// textures and the colour of each fruit, leaf and branch, decided per object
// from the scenario's seed so both cameras and every frame agree.
//
// Real canopy photographs differ from flat-shaded spheres and blades in ways
// a fruit detector trips over: dimpled, glossy peel with specular highlights,
// unripe and half-ripe fruit, leaves with a lighter midrib and veins that are
// waxy (white glints) on top and glow yellow-green when the sun is behind
// them, dry brown leaves, bark. The functions here give those.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "sim/scenario.hpp"

namespace harvest::sim {

using Vec3f = Eigen::Vector3f;

// A tileable value-noise texture (octaves from a period of size / 8 texels
// down to 2), values in [0, 1], the same in every process (fixed seeds).
// get(): 256 x 256 for large features; fine(): 64 x 64 (16 kB, stays in the
// L1 cache) for the high-frequency ones sampled far apart (peel dimples).
class NoiseTexture {
 public:
  static const NoiseTexture& get();
  static const NoiseTexture& fine();
  // Bilinear, wrapping; one unit is one texel.
  float sample(float x, float y) const {
    const int x0 = static_cast<int>(x) - (x < 0.0f), y0 = static_cast<int>(y) - (y < 0.0f);
    const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
    const int ix = x0 & mask_, iy = y0 & mask_, jx = (ix + 1) & mask_, jy = (iy + 1) & mask_;
    const float* t = t_.data();
    const float a = t[(iy << shift_) + ix], b = t[(iy << shift_) + jx];
    const float c = t[(jy << shift_) + ix], d = t[(jy << shift_) + jx];
    const float top = a + (b - a) * fx, bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
  }

 private:
  NoiseTexture(int shift, uint64_t seed);
  int shift_, mask_;
  std::vector<float> t_;
};

// A uniform number in [0, 1) from a seed and two integers (object kind, index).
double hashed_unit(uint64_t seed, uint64_t kind, uint64_t index);

enum class Ripeness : int8_t { kGreen = 0, kHalfRipe = 1, kRipe = 2 };

// How one fruit looks: its ripeness (from look.green_fraction and
// look.half_ripe_fraction), the orange it ripens to, the green it starts from,
// and where on the peel the green patches are.
struct FruitMaterial {
  Ripeness ripeness = Ripeness::kRipe;
  Vec3f orange = Vec3f(205, 128, 34);  // RGB albedo 0..255
  Vec3f green = Vec3f(96, 134, 44);
  float green_share = 0.0f;            // 0 ripe ... 1 green: threshold of the patch noise
  float texture_offset = 0.0f;
};
// `albedo` is the scene's peel colour (already spread per fruit).
FruitMaterial fruit_material(const Look& look, int fruit_id, const Vec3& albedo);

struct LeafMaterial {
  Vec3f albedo;      // RGB 0..255
  bool dry = false;  // brown, matte, no translucency
  float texture_offset = 0.0f;
};
LeafMaterial leaf_material(const Look& look, std::size_t leaf_index, const Vec3& albedo);

// Radiance (RGB, 0..255 at exposure 1) of a point on a fruit. `n` is the
// outward normal and `view` the unit vector towards the camera, both in the
// camera frame; `n_base` the normal in the base frame (texture coordinates
// stay on the peel when the camera moves); `sun` the unit vector towards the
// sun (camera frame), `up_base` the base frame's up; `sunlit` 0..1 from the
// shadow map.
Vec3f shade_fruit(const FruitMaterial& m, float radius_m, const Vec3f& n, const Vec3f& n_base, const Vec3f& view,
                  const Vec3f& sun, float up_dot, const Lighting& light, float sunlit);

// A point on a leaf blade: `qu` along the midrib (-1..1 tip to tip), `qv`
// across relative to the local half width (-1..1), `s_m` the position along
// the midrib in metres (fine texture); `n_face` the blade normal turned
// towards the camera, `across` the in-plane unit vector across the blade;
// `front_lit` whether the sun shines on the face the camera sees.
Vec3f shade_leaf(const LeafMaterial& m, float qu, float qv, float s_m, float t_m, const Vec3f& n_face,
                 const Vec3f& across, const Vec3f& view, const Vec3f& sun, const Lighting& light, float sunlit);

// A point on a branch (chain of spheres), textured by its base-frame position.
Vec3f shade_bark(const Vec3f& n, const Vec3f& p_base, const Vec3f& sun, float up_dot, const Lighting& light,
                 float sunlit);

// What is seen through a gap in the canopy along the base-frame direction
// `d` (unit): sky above the horizon, overexposed, and rows of trees and the
// ground below it.
Vec3f background(const Vec3f& d, const Vec3f& up, const Lighting& light);

}  // namespace harvest::sim
