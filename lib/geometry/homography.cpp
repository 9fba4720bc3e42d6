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

// Normalised DLT over the pairs in idx (eq. 2-17, 2-18).
Status dlt(const Points2& from, const Points2& to, const std::vector<int>& idx, Matrix3d& G) {
  if (idx.size() < 4) return Status::kTooFewPoints;
  Matrix3d Tf, Tt;
  if (!normalising_transform(from, idx, Tf) || !normalising_transform(to, idx, Tt)) return Status::kDegenerate;
  if (collinear(from, idx, Tf) || collinear(to, idx, Tt)) return Status::kDegenerate;
  Eigen::MatrixXd M(2 * idx.size(), 9);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const Vector3d a = Tf * from[idx[k]].homogeneous();
    const Vector3d b = Tt * to[idx[k]].homogeneous();
    // b x (G a) = 0, two independent rows per pair.
    M.row(2 * k) << 0, 0, 0, -b.z() * a.transpose(), b.y() * a.transpose();
    M.row(2 * k + 1) << b.z() * a.transpose(), 0, 0, 0, -b.x() * a.transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  // A second (near-)null direction means the pairs do not fix G.
  if (sv.size() >= 8 && sv(7) < 1e-10 * sv(0)) return Status::kDegenerate;
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Matrix3d Gn;
  Gn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  G = Tt.inverse() * Gn * Tf;
  const Eigen::JacobiSVD<Matrix3d> gs(G);
  if (!(gs.singularValues()(2) > 1e-12 * gs.singularValues()(0))) return Status::kDegenerate;
  if (std::abs(G(2, 2)) < 1e-14 * G.norm()) return Status::kDegenerate;  // g33 = 0 cannot be normalised
  G /= G(2, 2);
  return G.allFinite() ? Status::kOk : Status::kDegenerate;
}

void score(const Matrix3d& G, const Points2& from, const Points2& to, double threshold, HomographyFit& fit) {
  fit.inliers.assign(from.size(), 0);
  fit.num_inliers = 0;
  double sum = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double e = transfer_error(G, from[i], to[i]);
    if (e < threshold) {
      fit.inliers[i] = 1;
      ++fit.num_inliers;
      sum += e * e;
    }
  }
  fit.rms_error_px = fit.num_inliers > 0 ? std::sqrt(sum / fit.num_inliers) : 0.0;
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
    if (dlt(from, to, {s[0], s[1], s[2], s[3]}, G) != Status::kOk) continue;
    any_sample = true;
    HomographyFit trial;
    trial.G = G;
    score(G, from, to, params.threshold_px, trial);
    if (trial.num_inliers > best.num_inliers ||
        (trial.num_inliers == best.num_inliers && trial.rms_error_px < best.rms_error_px)) {
      best = trial;
      const double w = static_cast<double>(best.num_inliers) / n;
      const double p_fail = 1.0 - std::pow(w, 4);
      if (p_fail <= 1e-12) {
        needed = 0;
      } else {
        needed = static_cast<int>(std::ceil(std::log(1.0 - params.confidence) / std::log(p_fail)));
      }
    }
  }
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
    best = refined;
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
