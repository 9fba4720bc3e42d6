#include "geometry/homography.hpp"

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace harvest::geometry {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

const char* to_string(Status s) {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kTooFewPoints:
      return "fewer than four point pairs";
    case Status::kNonFinite:
      return "non-finite input";
    case Status::kDegenerate:
      return "degenerate configuration (collinear or coincident points)";
    case Status::kNoConsensus:
      return "fewer than four consistent pairs";
    case Status::kNoValidSolution:
      return "no decomposition satisfies the visibility constraints";
    case Status::kAmbiguous:
      return "two valid decompositions and no reference normal";
  }
  return "unknown";
}

namespace {

bool finite(const Points2& pts) {
  return std::all_of(pts.begin(), pts.end(), [](const Vector2d& p) { return p.allFinite(); });
}

// Hartley normalisation: centroid to the origin, mean distance sqrt(2).
// Returns false if all points coincide.
bool normalising_transform(const Points2& pts, const std::vector<int>& idx, Matrix3d& T) {
  Vector2d c = Vector2d::Zero();
  for (int i : idx) c += pts[i];
  c /= static_cast<double>(idx.size());
  double mean = 0.0;
  for (int i : idx) mean += (pts[i] - c).norm();
  mean /= static_cast<double>(idx.size());
  if (!(mean > 1e-12)) return false;
  const double s = std::sqrt(2.0) / mean;
  T << s, 0, -s * c.x(), 0, s, -s * c.y(), 0, 0, 1;
  return true;
}

// True if the selected points (already normalised to unit spread) lie on one
// line: the smaller eigenvalue of their scatter matrix vanishes.
bool collinear(const Points2& pts, const std::vector<int>& idx, const Matrix3d& T) {
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (int i : idx) {
    const Vector2d q = (T * pts[i].homogeneous()).hnormalized();
    S += q * q.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S);
  return es.eigenvalues()(0) < 1e-10 * std::max(1.0, es.eigenvalues()(1));
}

// Any three of four points collinear makes a minimal sample useless.
bool minimal_sample_degenerate(const Points2& pts, const std::array<int, 4>& s) {
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b)
      for (int c = b + 1; c < 4; ++c) {
        const Vector2d u = pts[s[b]] - pts[s[a]], v = pts[s[c]] - pts[s[a]];
        const double area = std::abs(u.x() * v.y() - u.y() * v.x());
        if (area < 1e-6 * std::max(1.0, u.squaredNorm() + v.squaredNorm())) return true;
      }
  return false;
}

// Normalised DLT over the pairs in idx (eq. 2-17, 2-18): G is the null
// vector of the 2n x 9 system M, found as the eigenvector of the smallest
// eigenvalue of the 9 x 9 matrix M^T M (the pairs are Hartley-normalised, so
// squaring the condition number costs no accuracy that matters here).
Status dlt(const Points2& from, const Points2& to, const std::vector<int>& idx, Matrix3d& G) {
  if (idx.size() < 4) return Status::kTooFewPoints;
  Matrix3d Tf, Tt;
  if (!normalising_transform(from, idx, Tf) || !normalising_transform(to, idx, Tt)) return Status::kDegenerate;
  if (collinear(from, idx, Tf) || collinear(to, idx, Tt)) return Status::kDegenerate;
  using Matrix9d = Eigen::Matrix<double, 9, 9>;
  using Vector9d = Eigen::Matrix<double, 9, 1>;
  Matrix9d MtM = Matrix9d::Zero();
  for (int i : idx) {
    const Vector3d a = Tf * from[i].homogeneous();
    const Vector3d b = Tt * to[i].homogeneous();
    // b x (G a) = 0, two independent rows per pair.
    Vector9d r1, r2;
    r1 << 0, 0, 0, -b.z() * a, b.y() * a;
    r2 << b.z() * a, 0, 0, 0, -b.x() * a;
    MtM.selfadjointView<Eigen::Lower>().rankUpdate(r1);
    MtM.selfadjointView<Eigen::Lower>().rankUpdate(r2);
  }
  const Eigen::SelfAdjointEigenSolver<Matrix9d> es(MtM.selfadjointView<Eigen::Lower>());
  const auto& ev = es.eigenvalues();  // ascending
  // A second (near-)null direction means the pairs do not fix G.
  if (ev(1) < 1e-14 * ev(8)) return Status::kDegenerate;
  const Vector9d h = es.eigenvectors().col(0);
  Matrix3d Gn;
  Gn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  G = Tt.inverse() * Gn * Tf;
  // Singular G: no homography between two views.
  if (!(std::abs(G.determinant()) > 1e-14 * std::pow(G.norm(), 3))) return Status::kDegenerate;
  if (std::abs(G(2, 2)) < 1e-14 * G.norm()) return Status::kDegenerate;  // g33 = 0 cannot be normalised
  G /= G(2, 2);
  return G.allFinite() ? Status::kOk : Status::kDegenerate;
}

// Transfer error of every pair under G against the threshold, into
// `inliers` (1/0); returns the count and the sum of squared inlier errors.
int score(const Matrix3d& G, const Points2& from, const Points2& to, double threshold, std::vector<uint8_t>& inliers,
          double& sum_sq) {
  const double t2 = threshold * threshold;
  const double g00 = G(0, 0), g01 = G(0, 1), g02 = G(0, 2), g10 = G(1, 0), g11 = G(1, 1), g12 = G(1, 2), g20 = G(2, 0),
               g21 = G(2, 1), g22 = G(2, 2);
  int count = 0;
  sum_sq = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double x = from[i].x(), y = from[i].y();
    const double w = g20 * x + g21 * y + g22;
    double e2 = std::numeric_limits<double>::infinity();
    if (std::abs(w) >= 1e-15) {
      const double ex = (g00 * x + g01 * y + g02) / w - to[i].x(), ey = (g10 * x + g11 * y + g12) / w - to[i].y();
      e2 = ex * ex + ey * ey;
    }
    const bool in = e2 < t2;
    inliers[i] = in;
    count += in;
    sum_sq += in ? e2 : 0.0;
  }
  return count;
}

void score(const Matrix3d& G, const Points2& from, const Points2& to, double threshold, HomographyFit& fit) {
  fit.inliers.resize(from.size());
  double sum = 0.0;
  fit.num_inliers = score(G, from, to, threshold, fit.inliers, sum);
  fit.rms_error_px = fit.num_inliers > 0 ? std::sqrt(sum / fit.num_inliers) : 0.0;
}

// The projective map of the unit square (0,0) (1,0) (1,1) (0,1) onto the
// quadrilateral q0..q3 (Heckbert's closed form). False when three corners
// are collinear.
bool square_to_quad(const Vector2d& q0, const Vector2d& q1, const Vector2d& q2, const Vector2d& q3, Matrix3d& M) {
  const double sx = q0.x() - q1.x() + q2.x() - q3.x(), sy = q0.y() - q1.y() + q2.y() - q3.y();
  const double dx1 = q1.x() - q2.x(), dx2 = q3.x() - q2.x(), dy1 = q1.y() - q2.y(), dy2 = q3.y() - q2.y();
  const double den = dx1 * dy2 - dx2 * dy1;
  if (!(std::abs(den) > 1e-12 * (dx1 * dx1 + dx2 * dx2 + dy1 * dy1 + dy2 * dy2))) return false;
  const double g = (sx * dy2 - dx2 * sy) / den, h = (dx1 * sy - sx * dy1) / den;
  M << q1.x() - q0.x() + g * q1.x(), q3.x() - q0.x() + h * q3.x(), q0.x(),  //
      q1.y() - q0.y() + g * q1.y(), q3.y() - q0.y() + h * q3.y(), q0.y(),   //
      g, h, 1.0;
  return true;
}

// Exact homography through four pairs (the RANSAC hypothesis):
// to ~ S_to S_from^-1 from, with S the square-to-quad maps.
bool four_point_homography(const Points2& from, const Points2& to, const std::array<int, 4>& s, Matrix3d& G) {
  Matrix3d Sf, St;
  if (!square_to_quad(from[s[0]], from[s[1]], from[s[2]], from[s[3]], Sf) ||
      !square_to_quad(to[s[0]], to[s[1]], to[s[2]], to[s[3]], St))
    return false;
  G = St * Sf.inverse();
  if (!G.allFinite() || std::abs(G(2, 2)) < 1e-14 * G.norm()) return false;
  G /= G(2, 2);
  return true;
}

}  // namespace

double transfer_error(const Matrix3d& G, const Vector2d& from, const Vector2d& to) {
  const Vector3d q = G * from.homogeneous();
  if (std::abs(q.z()) < 1e-15) return std::numeric_limits<double>::infinity();
  return (q.hnormalized() - to).norm();
}

HomographyFit fit_homography(const Points2& from, const Points2& to) {
  HomographyFit fit;
  if (from.size() != to.size() || from.size() < 4) {
    fit.status = Status::kTooFewPoints;
    return fit;
  }
  if (!finite(from) || !finite(to)) {
    fit.status = Status::kNonFinite;
    return fit;
  }
  std::vector<int> idx(from.size());
  std::iota(idx.begin(), idx.end(), 0);
  Matrix3d G;
  fit.status = dlt(from, to, idx, G);
  if (!fit.ok()) return fit;
  fit.G = G;
  score(G, from, to, std::numeric_limits<double>::infinity(), fit);
  return fit;
}

HomographyFit fit_homography_robust(const Points2& from, const Points2& to, const RansacParams& params) {
  HomographyFit best;
  if (from.size() != to.size() || from.size() < 4) {
    best.status = Status::kTooFewPoints;
    return best;
  }
  if (!finite(from) || !finite(to)) {
    best.status = Status::kNonFinite;
    return best;
  }
  const int n = static_cast<int>(from.size());
  std::mt19937_64 rng(params.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int needed = params.max_iterations;
  bool any_sample = false;
  std::vector<uint8_t> trial(from.size());
  best.inliers.assign(from.size(), 0);
  best.num_inliers = 0;
  double best_sum = 0.0;
  for (int it = 0; it < std::min(needed, params.max_iterations); ++it) {
    std::array<int, 4> s{};
    for (int k = 0; k < 4; ++k) {
      int c;
      do c = pick(rng);
      while (std::find(s.begin(), s.begin() + k, c) != s.begin() + k);
      s[k] = c;
    }
    if (minimal_sample_degenerate(from, s) || minimal_sample_degenerate(to, s)) continue;
    Matrix3d G;
    if (!four_point_homography(from, to, s, G)) continue;
    any_sample = true;
    double sum = 0.0;
    const int count = score(G, from, to, params.threshold_px, trial, sum);
    // More inliers, or as many with a smaller summed error (same count: same rms order).
    if (count > best.num_inliers || (count == best.num_inliers && count > 0 && sum < best_sum)) {
      best.G = G;
      best.num_inliers = count;
      best_sum = sum;
      best.inliers.swap(trial);
      trial.resize(from.size());
      const double w = static_cast<double>(count) / n;
      const double p_fail = 1.0 - std::pow(w, 4);
      if (p_fail <= 1e-12) {
        needed = 0;
      } else {
        needed = static_cast<int>(std::ceil(std::log(1.0 - params.confidence) / std::log(p_fail)));
      }
    }
  }
  best.rms_error_px = best.num_inliers > 0 ? std::sqrt(best_sum / best.num_inliers) : 0.0;
  if (!any_sample) {
    best.status = Status::kDegenerate;
    return best;
  }
  if (best.num_inliers < 4) {
    best.status = Status::kNoConsensus;
    return best;
  }
  // Refit on the consensus set, then re-score once with the refined model.
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<int> idx;
    for (int i = 0; i < n; ++i)
      if (best.inliers[i]) idx.push_back(i);
    Matrix3d G;
    const Status st = dlt(from, to, idx, G);
    if (st != Status::kOk) {
      best.status = st;
      return best;
    }
    HomographyFit refined;
    refined.G = G;
    score(G, from, to, params.threshold_px, refined);
    if (refined.num_inliers < 4) break;
    const bool same_set = refined.inliers == best.inliers;
    best = refined;
    if (same_set) break;  // a second refit on the same pairs would give the same G
  }
  best.status = Status::kOk;
  return best;
}

std::optional<Matrix3d> euclidean_homography(const Matrix3d& G, const Matrix3d& A_cur, const Matrix3d& A_ref,
                                             const Points3& m_ref) {
  if (!G.allFinite() || !A_cur.allFinite() || !A_ref.allFinite()) return std::nullopt;
  if (std::abs(A_cur.determinant()) < 1e-12 || std::abs(A_ref.determinant()) < 1e-12) return std::nullopt;
  Matrix3d H = A_cur.inverse() * G * A_ref;
  const Eigen::JacobiSVD<Matrix3d> svd(H);
  const double s2 = svd.singularValues()(1);
  if (!(s2 > 1e-12)) return std::nullopt;
  H /= s2;
  // alpha_i = 1 / (H m*_i)_3 must be positive: points lie in front of the camera.
  double votes = 0.0;
  for (const auto& m : m_ref) votes += (H * m).z() > 0 ? 1.0 : -1.0;
  if (votes < 0) H = -H;
  return H;
}

std::vector<double> depth_ratios(const Matrix3d& H, const Points3& m_ref) {
  std::vector<double> alpha;
  alpha.reserve(m_ref.size());
  for (const auto& m : m_ref) {
    const double z = (H * m).z();
    alpha.push_back(std::abs(z) > 1e-15 ? 1.0 / z : 0.0);
  }
  return alpha;
}

std::vector<Decomposition> decompose_homography_all(const Matrix3d& H) {
  std::vector<Decomposition> out;
  if (!H.allFinite()) return out;
  const Eigen::JacobiSVD<Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3d U = svd.matrixU(), V = svd.matrixV();
  const double d1 = svd.singularValues()(0), d2 = svd.singularValues()(1), d3 = svd.singularValues()(2);
  if (!(d2 > 1e-12)) return out;
  const double s = U.determinant() * V.determinant();
  if (d1 - d3 < 1e-9 * d2) {
    // Pure rotation: H = R, translation zero, normal unobservable.
    Decomposition d;
    d.R = nearest_rotation(H / d2);
    out.push_back(d);
    return out;
  }
  // Faugeras: H = d R + t n^T; Lambda = d' R' + t' n'^T with R = s U R' V^T,
  // t = U t', n = V n', d = s d'. H is scaled so d = +1, hence d' = s * d2.
  const double x1 = std::sqrt(std::max(0.0, (d1 * d1 - d2 * d2) / (d1 * d1 - d3 * d3)));
  const double x3 = std::sqrt(std::max(0.0, (d2 * d2 - d3 * d3) / (d1 * d1 - d3 * d3)));
  const double dprime = s * d2;
  for (double e1 : {1.0, -1.0}) {
    for (double e3 : {1.0, -1.0}) {
      const double a = e1 * x1, c = e3 * x3;
      Matrix3d Rp;
      Vector3d tp;
      if (dprime > 0) {
        const double st = (d1 - d3) * a * c / d2;
        const double ct = (d1 * d3 + d2 * d2) / ((d1 + d3) * d2);
        Rp << ct, 0, -st, 0, 1, 0, st, 0, ct;
        tp << (d1 - d3) * a, 0, -(d1 - d3) * c;
      } else {
        const double st = (d1 + d3) * a * c / d2;
        const double ct = (d1 * d3 - d2 * d2) / ((d1 - d3) * d2);
        Rp << ct, 0, st, 0, -1, 0, st, 0, -ct;
        tp << (d1 + d3) * a, 0, (d1 + d3) * c;
      }
      const double dd = s * dprime;  // == d2
      Decomposition d;
      d.R = s * U * Rp * V.transpose();
      d.n = V * Vector3d(a, 0, c);
      d.x_h = U * tp / dd;
      // Guard against sign slips: keep only exact reconstructions H = R + x n^T.
      if ((d.R + d.x_h * d.n.transpose() - H / dd).norm() > 1e-6 * std::max(1.0, H.norm() / dd)) continue;
      out.push_back(d);
    }
  }
  return out;
}

DecompositionResult decompose_homography(const Matrix3d& H, const Points3& m_ref, const Points3& m_cur,
                                         const std::optional<Vector3d>& reference_normal) {
  DecompositionResult res;
  const auto all = decompose_homography_all(H);
  if (all.empty()) {
    res.status = H.allFinite() ? Status::kDegenerate : Status::kNonFinite;
    return res;
  }
  if (all.size() == 1) {  // pure rotation
    res.status = Status::kOk;
    res.best = all.front();
    if (reference_normal) res.best.n = reference_normal->normalized();
    res.candidates = all;
    return res;
  }
  for (const auto& d : all) {
    const Vector3d nc = d.R * d.n;
    bool visible = true;
    for (const auto& m : m_ref) visible = visible && d.n.dot(m) > 0;
    for (const auto& m : m_cur) visible = visible && nc.dot(m) > 0;
    if (visible) res.candidates.push_back(d);
  }
  if (res.candidates.empty()) {
    // Near the goal the translation drowns in pixel noise: the normal is then
    // unobservable and the visibility test meaningless, but every solution
    // has (almost) the same rotation. Treat it as the pure-rotation case.
    double largest = 0;
    for (const auto& d : all) largest = std::max(largest, d.x_h.norm());
    if (largest > kNegligibleTranslation) {
      res.status = Status::kNoValidSolution;
      return res;
    }
    // Prefer the solution closest to the reference normal, else the one
    // with the most points passing the visibility test.
    auto visible_count = [&](const Decomposition& d) {
      int n = 0;
      const Vector3d nc = d.R * d.n;
      for (const auto& m : m_ref) n += d.n.dot(m) > 0;
      for (const auto& m : m_cur) n += nc.dot(m) > 0;
      return n;
    };
    res.candidates = all;
    std::stable_sort(res.candidates.begin(), res.candidates.end(), [&](const Decomposition& a, const Decomposition& b) {
      if (reference_normal) return a.n.dot(*reference_normal) > b.n.dot(*reference_normal);
      return visible_count(a) > visible_count(b);
    });
    res.best = res.candidates.front();
    res.status = Status::kOk;
    return res;
  }
  auto by_normal = [&](const Decomposition& a, const Decomposition& b) {
    return a.n.dot(*reference_normal) > b.n.dot(*reference_normal);
  };
  auto by_angle = [](const Decomposition& a, const Decomposition& b) {
    return angle_axis(a.R).theta < angle_axis(b.R).theta;
  };
  if (reference_normal) {
    std::sort(res.candidates.begin(), res.candidates.end(), by_normal);
    res.status = Status::kOk;
  } else {
    std::sort(res.candidates.begin(), res.candidates.end(), by_angle);
    res.status = res.candidates.size() == 1 ? Status::kOk : Status::kAmbiguous;
  }
  res.best = res.candidates.front();
  return res;
}

Matrix3d skew(const Vector3d& v) {
  Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Vector3d unskew(const Matrix3d& S) { return 0.5 * Vector3d(S(2, 1) - S(1, 2), S(0, 2) - S(2, 0), S(1, 0) - S(0, 1)); }

AngleAxis angle_axis(const Matrix3d& R) {
  AngleAxis aa;
  const double c = std::clamp(0.5 * (R.trace() - 1.0), -1.0, 1.0);
  aa.theta = std::acos(c);
  if (aa.theta < 1e-12) {
    aa.theta = 0.0;
    return aa;
  }
  // The rotation axis is the eigenvector of eigenvalue 1; for a matrix similar
  // to a rotation this is A~ u up to scale (eq. 5-41), which the
  // antisymmetric part would not give.
  const Eigen::JacobiSVD<Matrix3d> svd(R - Matrix3d::Identity(), Eigen::ComputeFullV);
  Vector3d u = svd.matrixV().col(2).normalized();
  if (u.dot(unskew(R)) < 0) u = -u;
  aa.u = u;
  return aa;
}

Matrix3d rotation_from_angle_axis(const Vector3d& u, double theta) {
  const Matrix3d S = skew(u);
  const double h = std::sin(0.5 * theta);
  return Matrix3d::Identity() + std::sin(theta) * S + 2.0 * h * h * S * S;
}

Matrix3d rotation_from_vector(const Vector3d& u_theta) {
  const double theta = u_theta.norm();
  if (theta < 1e-15) return Matrix3d::Identity() + skew(u_theta);
  return rotation_from_angle_axis(u_theta / theta, theta);
}

Matrix3d nearest_rotation(const Matrix3d& M) {
  const Eigen::JacobiSVD<Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d D = Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

Points3 normalise(const Matrix3d& A, const Points2& px) {
  const Matrix3d Ai = A.inverse();
  Points3 out;
  out.reserve(px.size());
  for (const auto& p : px) out.push_back(Ai * p.homogeneous());
  return out;
}

Matrix3d intrinsics(double lambda1, double lambda2, double phi, double u0, double v0) {
  Matrix3d A;
  A << lambda1, -lambda1 / std::tan(phi), u0, 0, lambda2 / std::sin(phi), v0, 0, 0, 1;
  return A;
}

}  // namespace harvest::geometry
