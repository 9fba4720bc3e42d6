// 3D fruit position from one detection (thesis section 6.2, eq. 6-10..6-15,
// 4-1, 6-13) with its uncertainty.
//
// Depth: eq. 6-10 per image axis, averaged (eq. 6-11 / 6-14). The apparent
// diameter is measured in undistorted normalised coordinates (the fruit's
// edges at u +- D/2 and v +- D/2 are undistorted through the camera model),
// so Z_x = D_o / d_x and Z_y = D_o / d_y. Without distortion and skew this is
// exactly f_x D_o / D and f_y D_o / D, i.e. the thesis formulas.
// Position in the camera frame: (x Z, y Z, Z) with (x, y) the undistorted
// normalised centre (eq. 6-12, 6-15).
//
// Uncertainty: the fruit diameter varies (sigma_D / D_o relative) and the
// apparent diameter and centre have pixel noise, so
//   var(Z) = Z^2 ((sigma_D / D_o)^2 + (sigma_diam_px / D_px)^2)
//   var(x) = (sigma_centre_px / f_x)^2, var(y) = (sigma_centre_px / f_y)^2
// propagated through (X, Y, Z) = (x Z, y Z, Z).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/camera_model.hpp"

#include "config/key.hpp"

namespace harvest::vision {

// The reconstructor's `fruit` and `pixel_noise` keys.
namespace fruit_keys {
inline constexpr config::Key<double> diameter_mean_m{"diameter_mean_m", 0.0725, {0.01, 0.5}, "m",
                                                     "mean fruit diameter D_o"};
inline constexpr config::Key<double> diameter_std_m{"diameter_std_m", 0.003, {0.0, 0.1}, "m",
                                                    "its standard deviation"};
inline constexpr config::Key<double> centre_px{"centre_px", 1.0, {0.0, 100.0}, "px", "1 sigma of the centroid"};
inline constexpr config::Key<double> diameter_px{"diameter_px", 1.0, {0.0, 100.0}, "px",
                                                 "1 sigma of the apparent diameter"};
}  // namespace fruit_keys

struct FruitStatistics {
  double diameter_mean_m = fruit_keys::diameter_mean_m.fallback;  // D_o
  double diameter_std_m = fruit_keys::diameter_std_m.fallback;
};

struct PixelNoise {
  double centre_px = fruit_keys::centre_px.fallback;
  double diameter_px = fruit_keys::diameter_px.fallback;
};

struct PointEstimate {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double depth_along_x = 0;  // eq. 6-10 along each image axis [m]
  double depth_along_y = 0;
};

// In the camera frame; nullopt-free: the caller guarantees diameter_px > 0.
PointEstimate reconstruct_in_camera(const geometry::CameraModel& cam, double u, double v, double diameter_px,
                                    const FruitStatistics& fruit, const PixelNoise& noise);

// Moves an estimate into another frame: p' = T p, C' = R C R^T, plus an
// isotropic uncertainty of the transform itself (calibration error) [m].
PointEstimate transform(const Eigen::Isometry3d& t, const PointEstimate& p, double transform_sigma_m = 0.0);

// The thesis's fixed-camera extrinsic (eq. 4-1): p_base = R_ef p_cam + T_ef.
Eigen::Isometry3d thesis_fixed_camera_extrinsic();

}  // namespace harvest::vision
