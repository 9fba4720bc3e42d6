// Planar homography estimation, Euclidean homography, decomposition and
// angle-axis conversion (thesis sections 2.3 and 5.3, appendix C).
//
// Conventions (thesis eq. 2-13..2-18 and 5-18..5-25): a point on the plane pi
// has normalised coordinates m* in the reference (desired) frame and m in the
// current frame; they are related by
//     m = alpha * (R + x_h n*^T) m*,   alpha = Z*/Z,   x_h = x_f / d*
// where R rotates reference-frame vectors into the current frame, x_f is the
// reference origin seen from the current frame, n* is the plane's unit normal
// in the reference frame and d* = n*^T (3D point in the reference frame) > 0.
// In pixels p = alpha * G p* with G = A H A*^{-1} (projective homography).
//
// Every function reports degenerate input through a status and never returns
// NaN: callers must check `ok()` before using the matrices.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace harvest::geometry {

enum class Status {
  kOk = 0,
  kTooFewPoints,     // fewer than four correspondences
  kNonFinite,        // NaN or infinity in the input
  kDegenerate,       // collinear points, rank-deficient system, singular matrix
  kNoConsensus,      // robust fit found fewer than four consistent pairs
  kNoValidSolution,  // no decomposition satisfies the visibility constraints
  kAmbiguous,        // two decompositions remain and no reference normal decides
};
const char* to_string(Status s);

using Points2 = std::vector<Eigen::Vector2d>;
using Points3 = std::vector<Eigen::Vector3d>;

struct HomographyFit {
  Status status = Status::kDegenerate;
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();  // to ~ G from, normalised so g33 = 1 (eq. 2-18)
  std::vector<uint8_t> inliers;                     // per pair, 1 = used in the final fit
  int num_inliers = 0;
  double rms_error_px = 0.0;  // transfer error over the inliers
  bool ok() const { return status == Status::kOk; }
};

// Normalised DLT (Hartley normalisation, SVD of the 2n x 9 system) from >= 4
// pairs, to_i ~ G from_i. Collinear/coincident points give kDegenerate.
HomographyFit fit_homography(const Points2& from, const Points2& to);

struct RansacParams {
  double threshold_px = 2.0;  // transfer-error threshold for an inlier
  int max_iterations = 2000;
  double confidence = 0.999;  // stop early when this confidence is reached
  uint64_t seed = 1;          // fixed seed: identical input gives identical output
};

// RANSAC over minimal four-point samples with a seeded RNG, then a
// normalised-DLT refit on all inliers. kNoConsensus if < 4 inliers.
HomographyFit fit_homography_robust(const Points2& from, const Points2& to, const RansacParams& params = {});

// One-way transfer error |to - dehomog(G from)| in pixels (infinite if the
// point maps to infinity).
double transfer_error(const Eigen::Matrix3d& G, const Eigen::Vector2d& from, const Eigen::Vector2d& to);

// Euclidean homography from a projective one with (estimated) intrinsics,
// eq. 5-25: H = A_cur^{-1} G A_ref, scaled to unit middle singular value and
// signed so that the reference points map in front of the camera. Returns
// nullopt for singular intrinsics or non-finite input.
std::optional<Eigen::Matrix3d> euclidean_homography(const Eigen::Matrix3d& G, const Eigen::Matrix3d& A_cur,
                                                    const Eigen::Matrix3d& A_ref, const Points3& m_ref);

// Depth ratios alpha_i = Z*_i / Z_i for a correctly scaled Euclidean
// homography (eq. 2-16, 5-19): m_i = alpha_i H m*_i with m_i,3 = 1.
std::vector<double> depth_ratios(const Eigen::Matrix3d& H, const Points3& m_ref);

struct Decomposition {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // reference -> current rotation
  Eigen::Vector3d x_h = Eigen::Vector3d::Zero();    // translation / d*
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();     // unit normal in the reference frame
};

// All solutions of H = R + x_h n^T (Faugeras & Lustman, as used in thesis
// appendix C): four for a general H (two sign pairs), one for a pure rotation
// (then n is unobservable and set to +z). H must have unit middle singular
// value (see euclidean_homography). Empty for non-finite input.
std::vector<Decomposition> decompose_homography_all(const Eigen::Matrix3d& H);

struct DecompositionResult {
  Status status = Status::kNoValidSolution;
  Decomposition best;                     // valid when status is kOk or kAmbiguous
  std::vector<Decomposition> candidates;  // solutions passing the visibility test
  bool ok() const { return status == Status::kOk; }
};

// Decomposes H and keeps the physically valid solutions: every reference
// point in front of the plane in both frames (n^T m* > 0, (R n)^T m > 0).
// With a reference normal the candidate closest to it wins; without one, two
// survivors give kAmbiguous (best = the one with the smaller rotation).
// When no solution passes the visibility test but every |x_h| is below
// kNegligibleTranslation (noise at the goal pose: the normal is unobservable
// there), all solutions are kept and the result is kOk, as for a pure rotation.
inline constexpr double kNegligibleTranslation = 1e-2;  // 1 % of the plane distance
DecompositionResult decompose_homography(const Eigen::Matrix3d& H, const Points3& m_ref, const Points3& m_cur,
                                         const std::optional<Eigen::Vector3d>& reference_normal = std::nullopt);

// ---- rotations ----
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
Eigen::Vector3d unskew(const Eigen::Matrix3d& S);  // vector of the antisymmetric part

struct AngleAxis {
  Eigen::Vector3d u = Eigen::Vector3d::UnitZ();  // unit axis
  double theta = 0.0;                            // [0, pi]
  Eigen::Vector3d vector() const { return u * theta; }
};

// Angle-axis of R (eq. 5-34, 5-35). Also valid for a matrix only *similar*
// to a rotation, R^ = A~ R A~^{-1} (eq. 5-27, 5-41): theta from the trace,
// u the unit eigenvector of eigenvalue 1, signed like the antisymmetric part.
AngleAxis angle_axis(const Eigen::Matrix3d& R);
// Rodrigues form, eq. 5-36.
Eigen::Matrix3d rotation_from_angle_axis(const Eigen::Vector3d& u, double theta);
Eigen::Matrix3d rotation_from_vector(const Eigen::Vector3d& u_theta);
// Nearest rotation (Frobenius norm) of a 3x3 matrix.
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M);

// Normalised coordinates A^{-1} [u v 1]^T of pixel points.
Points3 normalise(const Eigen::Matrix3d& A, const Points2& px);
// Upper-triangular intrinsics of eq. 5-9 (skew angle phi, focal products lambda1/2).
Eigen::Matrix3d intrinsics(double lambda1, double lambda2, double phi, double u0, double v0);

}  // namespace harvest::geometry
