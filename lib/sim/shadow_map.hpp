// Cast shadows of the canopy for the "field" look: a height field of the
// leaves and branches seen from the sun (orthographic, base frame). A point
// is in sunlight when nothing lies between it and the sun, i.e. when it is
// at least as far towards the sun as the highest occluder over its cell.
// Fruit cast no shadow (they sway and get picked; the map is built once per
// scene and sun).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "sim/scene.hpp"

namespace harvest::sim {

class ShadowMap {
 public:
  // Builds the map when the scene's canopy or the sun changed since the last
  // call (the first call builds it).
  void update(const Scene& scene, int cells = 512);

  // Share of sunlight (0..1, bilinear over four cells) at base-frame point p
  // of a surface whose normal makes angle acos(cos_sun) with the sun.
  float sunlit(const Eigen::Vector3f& p, float cos_sun) const;

  // The same for points in a camera frame (`rotation`, `position`: the
  // camera in the base frame), without going through the base frame per point.
  class View {
   public:
    float sunlit(const Eigen::Vector3f& p_cam, float cos_sun) const;

   private:
    friend class ShadowMap;
    const ShadowMap* map_ = nullptr;
    Eigen::Vector3f a_, b_, s_;  // the light frame's axes in the camera frame
    float au_ = 0, bv_ = 0, sw_ = 0;
  };
  View view(const Eigen::Matrix3f& rotation, const Eigen::Vector3f& position) const;

 private:
  void build(const Scene& scene, int cells);
  float lookup(float gu, float gv, float w, float cos_sun) const;

  const Scene* scene_ = nullptr;
  std::size_t leaves_ = 0, beads_ = 0;
  Eigen::Vector3d sun_ = Eigen::Vector3d::Zero();
  Eigen::Vector3f a_, b_, s_;  // light frame: two axes across the sun, one towards it
  float u0_ = 0, v0_ = 0, inv_cell_ = 1, cell_ = 1;
  int n_ = 0;
  std::vector<float> top_;  // highest occluder towards the sun per cell; -inf: none
};

}  // namespace harvest::sim
