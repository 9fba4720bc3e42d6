// Small scenarios built in code for the simulator's unit tests.
#pragma once

#include "sim/scenario.hpp"

namespace harvest::sim::test {

// One fruit 1 m in front of a fixed camera at the base origin looking along
// base +y (the thesis extrinsic rotation), no canopy, no noise.
inline Scenario one_fruit(const Vec3& fruit = Vec3(0.0, 1.0, 0.0), double diameter = 0.07) {
  Scenario s;
  s.name = "unit";
  s.fruit.push_back({fruit, diameter});
  s.fixed_camera.model = geometry::CameraModel::from_thesis(416.8, 383.5, 1.5707963267948966, 159.5, 119.5, 320, 240,
                                                            {-0.12, 0.05, 0.001, -0.001, 0.0});
  s.fixed_camera.noise_std = 0.0;
  s.hand_camera = s.fixed_camera;
  s.fixed_camera_truth.rotation << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  return s;
}

}  // namespace harvest::sim::test
