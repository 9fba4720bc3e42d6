#include "vision/reconstruction.hpp"

namespace harvest::vision {

PointEstimate reconstruct_in_camera(const geometry::CameraModel& cam, double u, double v, double diameter_px,
                                    const FruitStatistics& fruit, const PixelNoise& noise) {
  const double h = 0.5 * diameter_px;
  const Eigen::Vector2d m = cam.undistort_to_normalized({u, v});
  const double dx = cam.undistort_to_normalized({u + h, v}).x() - cam.undistort_to_normalized({u - h, v}).x();
  const double dy = cam.undistort_to_normalized({u, v + h}).y() - cam.undistort_to_normalized({u, v - h}).y();
  PointEstimate e;
  e.depth_along_x = fruit.diameter_mean_m / dx;
  e.depth_along_y = fruit.diameter_mean_m / dy;
  const double z = 0.5 * (e.depth_along_x + e.depth_along_y);
  e.position = {m.x() * z, m.y() * z, z};

  const double rel_d = fruit.diameter_std_m / fruit.diameter_mean_m;
  const double rel_px = noise.diameter_px / diameter_px;
  const double var_z = z * z * (rel_d * rel_d + rel_px * rel_px);
  const double sx = noise.centre_px / cam.fx, sy = noise.centre_px / cam.fy;
  Eigen::Matrix3d j;  // d(X, Y, Z) / d(x, y, Z)
  j << z, 0, m.x(), 0, z, m.y(), 0, 0, 1;
  e.covariance = j * Eigen::Vector3d(sx * sx, sy * sy, var_z).asDiagonal() * j.transpose();
  return e;
}

PointEstimate transform(const Eigen::Isometry3d& t, const PointEstimate& p, double transform_sigma_m) {
  PointEstimate out = p;
  out.position = t * p.position;
  out.covariance = t.linear() * p.covariance * t.linear().transpose() +
                   transform_sigma_m * transform_sigma_m * Eigen::Matrix3d::Identity();
  return out;
}

Eigen::Isometry3d thesis_fixed_camera_extrinsic() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  t.translation() << -0.254, 0.19685, -0.381;
  return t;
}

}  // namespace harvest::vision
