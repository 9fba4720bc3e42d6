#include "control/tbz_controller.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "config/config.hpp"

namespace harvest::control {

using Eigen::Matrix3d;
using Eigen::Vector3d;
namespace geo = harvest::geometry;

Twist robot_to_camera(const Twist& robot, const Matrix3d& R_r, const Vector3d& t_r) {
  Twist c;
  c.w = R_r * robot.w;
  c.v = R_r * robot.v + geo::skew(t_r) * c.w;
  return c;
}

Twist camera_to_robot(const Twist& camera, const Matrix3d& R_r, const Vector3d& t_r) {
  Twist r;
  r.w = R_r.transpose() * camera.w;
  r.v = R_r.transpose() * (camera.v - geo::skew(t_r) * camera.w);
  return r;
}

double translation_gain_f(double me1, double me2) {
  const double q = 0.5 * (me1 * me1 + me2 * me2) + 1.0;
  return (q - std::sqrt(q * q - 1.0)) / 3.0;
}

const char* to_string(TbzStatus s) {
  switch (s) {
    case TbzStatus::kOk:
      return "ok";
    case TbzStatus::kTooFewPoints:
      return "fewer than four point pairs";
    case TbzStatus::kDegenerate:
      return "degenerate point configuration";
    case TbzStatus::kNoValidSolution:
      return "no physically valid homography decomposition";
    case TbzStatus::kNonFinite:
      return "non-finite input";
    case TbzStatus::kBadIndex:
      return "translation point index out of range";
  }
  return "unknown";
}

namespace {
std::vector<double> row_major_values(const Matrix3d& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}
}  // namespace

TbzParams TbzParams::thesis_simulation() {
  TbzParams p;
  p.A_hat << 120, -4, 122, 0, 121, 123, 0, 0, 1;
  p.R_r_hat << 0.9220, -0.1844, 0.3404, 0.3404, 0.8050, -0.4858, -0.1844, 0.5638, 0.8050;
  p.R_r_hat = geo::nearest_rotation(p.R_r_hat);
  p.max_linear_speed = p.max_angular_speed = 0.0;  // the thesis simulation has no output limits
  return p;
}

TbzParams TbzParams::from_config(const config::Node& node) {
  TbzParams d;
  d.A_hat = thesis_simulation().A_hat;
  return from_config(node, d);
}

TbzParams TbzParams::from_config(const config::Node& node, const TbzParams& d) {
  namespace k = tbz_keys;
  TbzParams p;
  const auto a = node.get(k::A_hat, row_major_values(d.A_hat));
  p.A_hat = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data());
  if (std::abs(p.A_hat.determinant()) < 1e-9) node.fail("A_hat", "an invertible 3x3 matrix (row major)");
  const auto r = node.get(k::R_r_hat, row_major_values(d.R_r_hat));
  const Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.data());
  if ((R * R.transpose() - Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    node.fail("R_r_hat", "a rotation matrix (row major, orthonormal to 1e-3)");
  p.R_r_hat = geo::nearest_rotation(R);
  p.lambda_w = node.get(k::lambda_w, d.lambda_w);
  p.gain_function = node.choice(k::lambda_v_mode.name, d.gain_function ? "gain_function" : "constant",
                                k::lambda_v_mode.list()) == "gain_function";
  p.lambda_v = node.get(k::lambda_v, d.lambda_v);
  p.kn0 = node.get(k::kn0, d.kn0);
  p.kn1 = node.get(k::kn1, d.kn1);
  p.kn2 = node.get(k::kn2, d.kn2);
  p.desired_depth_estimate = node.get(k::desired_depth_estimate_m, d.desired_depth_estimate);
  p.translation_point = node.get(k::translation_point, d.translation_point);
  p.max_linear_speed = node.get(k::max_linear_speed, d.max_linear_speed);
  p.max_angular_speed = node.get(k::max_angular_speed, d.max_angular_speed);
  const auto n = node.get(k::reference_normal,
                          {d.reference_normal.x(), d.reference_normal.y(), d.reference_normal.z()});
  p.reference_normal = Vector3d(n[0], n[1], n[2]);
  if (p.reference_normal.norm() < 1e-9) node.fail("reference_normal", "a non-zero 3-vector");
  p.reference_normal.normalize();
  return p;
}

config::Section TbzParams::schema(const std::string& path, const std::string& where) {
  namespace k = tbz_keys;
  return config::section(path, where, k::A_hat, k::R_r_hat, k::lambda_w, k::lambda_v_mode, k::lambda_v, k::kn0, k::kn1,
                         k::kn2, k::desired_depth_estimate_m, k::translation_point, k::max_linear_speed,
                         k::max_angular_speed, k::reference_normal);
}

TbzController::TbzController(TbzParams params) : params_(std::move(params)), A_hat_inv_(params_.A_hat.inverse()) {}

TbzOutput TbzController::fail(TbzStatus s, std::string message) const {
  TbzOutput out;
  out.status = s;
  out.message = std::move(message);
  return out;
}

namespace {
TbzStatus from_geometry(geo::Status s) {
  switch (s) {
    case geo::Status::kTooFewPoints:
      return TbzStatus::kTooFewPoints;
    case geo::Status::kNonFinite:
      return TbzStatus::kNonFinite;
    case geo::Status::kNoValidSolution:
      return TbzStatus::kNoValidSolution;
    default:
      return TbzStatus::kDegenerate;
  }
}

void saturate(Vector3d& v, double limit, bool& saturated) {
  const double n = v.norm();
  if (limit > 0 && n > limit) {
    v *= limit / n;
    saturated = true;
  }
}
}  // namespace

TbzOutput TbzController::step(const TbzMeasurement& m) {
  const auto& P = params_;
  const std::size_t k = static_cast<std::size_t>(P.translation_point);
  if (m.current_px.size() != m.desired_px.size() || m.current_px.size() < 4)
    return fail(TbzStatus::kTooFewPoints, "need >= 4 matched target points");
  if (k >= m.current_px.size()) return fail(TbzStatus::kBadIndex, "translation_point out of range");

  const auto fit = geo::fit_homography(m.desired_px, m.current_px);
  if (!fit.ok())
    return fail(from_geometry(fit.status), std::string("target homography: ") + geo::to_string(fit.status));
  const geo::Points3 md = geo::normalise(P.A_hat, m.desired_px);  // eq. 5-15
  const geo::Points3 mc = geo::normalise(P.A_hat, m.current_px);  // eq. 5-13

  TbzOutput out;
  Matrix3d Rd_hat;
  Matrix3d Hd_hat;
  if (m.current_vanishing_px.size() >= 4 && m.current_vanishing_px.size() == m.desired_vanishing_px.size()) {
    // Section 5.3: on the plane at infinity H_d^ = R_d^ = A^-1 G_inf A^, up to scale.
    const auto vfit = geo::fit_homography(m.desired_vanishing_px, m.current_vanishing_px);
    if (!vfit.ok())
      return fail(from_geometry(vfit.status), std::string("vanishing points: ") + geo::to_string(vfit.status));
    Rd_hat = A_hat_inv_ * vfit.G * P.A_hat;
    const double det = Rd_hat.determinant();
    if (!(std::abs(det) > 1e-12)) return fail(TbzStatus::kDegenerate, "vanishing-point homography is singular");
    Rd_hat /= std::cbrt(det);  // similar to a rotation: det = 1
    // Scale of H_d^: R_d^-1 H_d^ = A~ (I + R^T x n^T) A~^-1 has a double
    // eigenvalue 1, so the closest eigenvalue pair of R_d^-1 (A^-1 G A) fixes it.
    const Matrix3d Hn = A_hat_inv_ * fit.G * P.A_hat;
    const Eigen::Vector3cd ev = Eigen::EigenSolver<Matrix3d>(Rd_hat.inverse() * Hn).eigenvalues();
    double best = std::numeric_limits<double>::infinity(), pair = 1.0;
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        if (std::abs(ev(i) - ev(j)) < best) {
          best = std::abs(ev(i) - ev(j));
          pair = 0.5 * (ev(i).real() + ev(j).real());
        }
    if (!(std::abs(pair) > 1e-12)) return fail(TbzStatus::kDegenerate, "cannot scale the Euclidean homography");
    Hd_hat = Hn / pair;
    out.from_vanishing_points = true;
  } else {
    const auto H = geo::euclidean_homography(fit.G, P.A_hat, P.A_hat, md);  // eq. 5-25
    if (!H) return fail(TbzStatus::kDegenerate, "cannot form the Euclidean homography");
    const auto dec = geo::decompose_homography(*H, md, mc, last_normal_.value_or(P.reference_normal));
    if (!dec.ok()) return fail(from_geometry(dec.status), std::string("decomposition: ") + geo::to_string(dec.status));
    Rd_hat = dec.best.R;
    Hd_hat = *H;
    last_normal_ = dec.best.n;
  }

  const auto alpha = geo::depth_ratios(Hd_hat, md);
  out.alpha1 = alpha[k];
  if (!(out.alpha1 > 0) || !std::isfinite(out.alpha1))
    return fail(TbzStatus::kNoValidSolution, "target point behind the camera (alpha <= 0)");

  // Rotation law, eq. 5-40, 5-44 (sign: see header).
  const auto aa = geo::angle_axis(Rd_hat);
  out.theta = aa.theta;
  out.e_w = aa.vector();
  out.robot.w = P.lambda_w * P.R_r_hat.transpose() * out.e_w;

  // Translation law, eq. 5-55, 5-60..5-63.
  const double me1 = mc[k].x(), me2 = mc[k].y();
  out.e_v = Vector3d(me1 - md[k].x(), me2 - md[k].y(), -std::log(out.alpha1));  // ln(Z1/Z1*) = -ln(alpha1)
  out.depth1 = P.desired_depth_estimate / out.alpha1;
  const double z2 = out.depth1 * out.depth1;
  Matrix3d Lv;
  Lv << -1, 0, me1, 0, -1, me2, 0, 0, -1;
  Lv /= out.depth1;
  out.lambda_v = P.gain_function ? P.kn0 + z2 / translation_gain_f(me1, me2) : P.lambda_v;
  const double gain = out.lambda_v + P.kn1 * z2 + P.kn2 * z2 * out.e_v.squaredNorm();
  out.robot.v = -gain * P.R_r_hat.transpose() * Lv.transpose() * out.e_v;

  saturate(out.robot.v, P.max_linear_speed, out.saturated);
  saturate(out.robot.w, P.max_angular_speed, out.saturated);
  if (!out.robot.v.allFinite() || !out.robot.w.allFinite())
    return fail(TbzStatus::kNonFinite, "non-finite velocity (check the intrinsics estimate)");
  out.camera_estimate = robot_to_camera(out.robot, P.R_r_hat, Vector3d::Zero());
  out.status = TbzStatus::kOk;
  return out;
}

}  // namespace harvest::control
