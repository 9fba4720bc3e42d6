// A textured rectangle on a plane, drawn by an extra Renderer::Primitive
// (calibration boards, fruit stickers): ray-plane intersection per pixel,
// each pixel area-sampled so printed edges land where the camera model puts
// them.
#pragma once

#include <functional>

#include "sim/renderer.hpp"

namespace harvest::sim {

struct PlanePatch {
  Vec3 origin;            // camera frame [m]
  Vec3 ex, ey;            // unit in-plane axes (camera frame)
  Vec3 normal;            // unit, camera frame: the printed face looks along -normal (not ex x ey:
                          // a camera frame may be improper, as the thesis's fixed camera's)
  double u0, u1, v0, v1;  // the rectangle in plane coordinates [m]
  int samples = 16;       // sub-pixel rays per pixel (n-rooks: each in its own 1/samples column and row)
  int stride = 5;         // coprime with samples: sample k sits at column k, row k * stride mod samples
};

// Albedo (RGB 0..255) at plane point (u, v); `front`: the camera is on the
// side the normal points away from (the printed face).
using PatchAlbedo = std::function<Vec3(double u, double v, bool front)>;

// Draws `patch` (only if its four corners are at least 1 cm in front of the
// lens); a pixel's albedo is the mean over its sub-pixel rays (the back face
// is sampled once).
void draw_plane_patch(Renderer::Canvas& canvas, const PlanePatch& patch, const PatchAlbedo& albedo);

}  // namespace harvest::sim
