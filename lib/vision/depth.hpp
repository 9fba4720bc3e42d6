// Depth from apparent size (thesis eq. 6-10, 6-11, 6-14).
//
// A fruit of diameter D_o seen D_px pixels wide by a camera with focal length
// f (the product of focal length and scaling factor along that axis, [px]) is
// at depth Z = f D_o / D_px. With separate x and y focal lengths the thesis
// estimates along each axis and averages (eq. 6-10, 6-11, table 6-2).
#pragma once

namespace harvest::vision {

struct DepthEstimate {
  double along_x;  // [m] (or the unit of the diameters)
  double along_y;
  double mean;
};

// eq. 6-10 per axis and their mean; table 6-2 uses separate object sizes.
inline DepthEstimate depth_from_size(double fx, double fy, double object_x, double object_y, double image_x_px,
                                     double image_y_px) {
  const double zx = fx * object_x / image_x_px;
  const double zy = fy * object_y / image_y_px;
  return {zx, zy, 0.5 * (zx + zy)};
}

// eq. 6-11 / 6-14: one statistical diameter and one apparent diameter.
inline double depth_from_diameter(double fx, double fy, double object_diameter, double image_diameter_px) {
  return (fx + fy) * object_diameter / (2.0 * image_diameter_px);
}

}  // namespace harvest::vision
