#include "control/tbz_simulation.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "config/config.hpp"

namespace harvest::control {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace geo = harvest::geometry;

namespace {

Matrix3d row_major(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v.data());
}

geo::Points2 pairs(const std::vector<double>& v) {
  geo::Points2 out;
  for (std::size_t i = 0; i + 1 < v.size(); i += 2) out.emplace_back(v[i], v[i + 1]);
  return out;
}

std::vector<double> flat(const geo::Points2& p) {
  std::vector<double> out;
  for (const auto& q : p) {
    out.push_back(q.x());
    out.push_back(q.y());
  }
  return out;
}

Vector2d project(const Matrix3d& A, const Vector3d& X) { return (A * X).hnormalized(); }

// The scene as a function of the fitted parameters q = (a, b, rotation vector, t):
// plane normal (a, b, 1)/|.| in F_d and the initial pose of F.
struct SceneModel {
  const ThesisScenario& s;
  geo::Points3 rays, dirs;

  // The tilt of the plane from the goal camera's axis is bounded (a target
  // seen edge-on has no trackable features): (a, b) = tan(max) w / sqrt(1 + |w|^2).
  Vector3d normal(const VectorXd& q) const {
    const Eigen::Vector2d w(q(0), q(1));
    const Eigen::Vector2d ab = std::tan(s.max_plane_tilt) * w / std::sqrt(1.0 + w.squaredNorm());
    return Vector3d(ab.x(), ab.y(), 1.0).normalized();
  }
  geo::Points3 points(const VectorXd& q) const {
    const Vector3d n = normal(q);
    const double d = s.desired_depth * n.dot(rays[0]);  // fixes Z of point 1 at F_d
    geo::Points3 X;
    for (const auto& r : rays) X.push_back(r * (d / n.dot(r)));
    return X;
  }
  VectorXd residual(const VectorXd& q) const {
    const Matrix3d R = geo::rotation_from_vector(q.segment<3>(2));
    const Vector3d t = q.segment<3>(5);
    const auto X = points(q);
    VectorXd r(4 * X.size());
    for (std::size_t i = 0; i < X.size(); ++i) r.segment<2>(2 * i) = project(s.A, R * X[i] + t) - s.p0[i];
    const std::size_t off = 2 * X.size();
    for (std::size_t j = 0; j < dirs.size(); ++j)
      r.segment<2>(off + 2 * j) = s.vanishing_weight * (project(s.A, R * dirs[j]) - s.vanish0[j]);
    return r;
  }
};

// Levenberg-Marquardt with a central-difference Jacobian (8 parameters, 16 residuals).
VectorXd levenberg_marquardt(const SceneModel& m, VectorXd q) {
  double lambda = 1e-3;
  VectorXd r = m.residual(q);
  double cost = r.squaredNorm();
  for (int it = 0; it < 500 && lambda < 1e12; ++it) {
    Eigen::MatrixXd J(r.size(), q.size());
    for (int k = 0; k < q.size(); ++k) {
      VectorXd a = q, b = q;
      a(k) += 1e-7;
      b(k) -= 1e-7;
      J.col(k) = (m.residual(a) - m.residual(b)) / 2e-7;
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const VectorXd g = J.transpose() * r;
    Eigen::MatrixXd Aug = JtJ;
    Aug.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-12);
    const VectorXd step = Aug.ldlt().solve(-g);
    const VectorXd qn = q + step;
    const VectorXd rn = m.residual(qn);
    if (rn.allFinite() && rn.squaredNorm() < cost) {
      q = qn;
      r = rn;
      const bool done = cost - rn.squaredNorm() < 1e-15 * (1 + cost);
      cost = rn.squaredNorm();
      lambda = std::max(lambda * 0.3, 1e-12);
      if (done) break;
    } else {
      lambda *= 10;
    }
  }
  return q;
}

}  // namespace

ThesisScenario ThesisScenario::thesis() {
  ThesisScenario s;
  s.A = geo::intrinsics(122.5, 122.5, 1.53, 120, 120);
  s.A_f = geo::intrinsics(147, 147, 1.53, 120, 120);
  s.A_star = geo::intrinsics(294, 294, 1.53, 120, 120);
  Matrix3d R;
  R << 0.95692, -0.065563, 0.28284, 0.11725, 0.97846, -0.16989, -0.26561, 0.19574, 0.944;
  s.R_r = geo::nearest_rotation(R);  // the published matrix is orthonormal to ~1e-5
  s.t_r = Vector3d(0.02, 0.04, 0.03);
  s.p_f = {{121.9, 120.4}, {121.7, 121.2}, {121.0, 121.0}, {121.2, 120.3}};
  s.p_star = {{129.4, 122.2}, {128.6, 125.75}, {125.0, 125.2}, {125.7, 121.6}};
  s.p0 = {{113.7, 113.5}, {116.4, 114.0}, {115.8, 115.6}, {113.2, 115.2}};
  s.vanish_star = {{134.1, 134.7}, {135.3, 105.3}, {105.9, 105.3}, {104.7, 134.7}};
  s.vanish0 = {{76.5, 276.7}, {144, 199}, {138, 192}, {143, 192}};
  return s;
}

namespace {
// The keys of the `scenario` mapping of config/tbz/thesis_sim.yaml; a missing
// key takes the thesis's value (section 5.6.2, ThesisScenario::thesis()).
namespace sk {
using config::Key;
using config::Numbers;
constexpr const char* kThesis = "the thesis's";
constexpr Numbers camera_in_hand{.name = "camera_in_hand", .size = 5,
                                 .doc = "true in-hand intrinsics [lambda1, lambda2, phi, u0, v0] (eq. 5-9)",
                                 .derived = kThesis};
constexpr Numbers fixed_camera{.name = "fixed_camera", .size = 5, .doc = "fixed camera intrinsics, the same form",
                               .derived = kThesis};
constexpr Numbers zoomed_camera{.name = "zoomed_camera", .size = 5,
                                .doc = "fixed camera after zooming, the same form", .derived = kThesis};
constexpr Numbers R_r{.name = "R_r", .size = 9, .doc = "true camera <- end-effector rotation, row major (eq. 5-65)",
                      .derived = kThesis};
constexpr Numbers t_r_m{"t_r_m", 3, {0.02, 0.04, 0.03}, "m",
                        "true end-effector origin in the camera frame (eq. 5-66)"};
constexpr Numbers p_f{.name = "p_f", .size = 8, .unit = "px", .doc = "fixed-camera pixels of the 4 points",
                      .derived = kThesis};
constexpr Numbers p_star{.name = "p_star", .size = 8, .unit = "px", .doc = "zoomed fixed-camera pixels",
                         .derived = kThesis};
constexpr Numbers p_initial{.name = "p_initial", .size = 8, .unit = "px", .doc = "initial in-hand pixels",
                            .derived = kThesis};
constexpr Numbers vanishing_star{.name = "vanishing_star", .size = 8, .unit = "px",
                                 .doc = "vanishing points, zoomed fixed camera", .derived = kThesis};
constexpr Numbers vanishing_initial{.name = "vanishing_initial", .size = 8, .unit = "px",
                                    .doc = "vanishing points, initial in-hand", .derived = kThesis};
constexpr Key<double> desired_depth_m{"desired_depth_m", 1.0, {1e-3, 100.0}, "m",
                                      "Z of point 1 at F_d (not given by the thesis)"};
constexpr Key<double> vanishing_weight{"vanishing_weight", 0.01, {1e-6, 1e6}, "",
                                       "vanishing-point residuals' weight in the scene fit (a weak prior)"};
constexpr Key<double> max_plane_tilt_deg{"max_plane_tilt_deg", 60.0, {0.0, 89.0}, "deg",
                                         "bound on the target plane's tilt at F_d"};
}  // namespace sk
}  // namespace

std::vector<config::Section> ThesisScenario::schema() {
  const std::string where = "harvest-tbz-sim, config/tbz/thesis_sim.yaml (docs/teach-by-zooming.md).";
  return {config::section("tbz_sim.scenario", where, sk::camera_in_hand, sk::fixed_camera, sk::zoomed_camera, sk::R_r,
                          sk::t_r_m, sk::p_f, sk::p_star, sk::p_initial, sk::vanishing_star, sk::vanishing_initial,
                          sk::desired_depth_m, sk::vanishing_weight, sk::max_plane_tilt_deg),
          TbzParams::schema("tbz_sim.controller", where + " Defaults: the thesis simulation's for harvest-tbz-sim.")};
}

ThesisScenario ThesisScenario::from_config(const config::Node& node) {
  ThesisScenario s = thesis();
  auto cam = [&](const config::Numbers& key, const Matrix3d& fallback) {
    const auto v =
        node.get(key, {fallback(0, 0), fallback(1, 1) * std::sin(1.53), 1.53, fallback(0, 2), fallback(1, 2)});
    if (v[0] <= 0 || v[1] <= 0 || v[2] <= 0.1 || v[2] >= M_PI - 0.1)
      node.fail(key.name, "[lambda1, lambda2, phi, u0, v0] with positive focal products and 0.1 < phi < pi - 0.1");
    return geo::intrinsics(v[0], v[1], v[2], v[3], v[4]);
  };
  s.A = cam(sk::camera_in_hand, s.A);
  s.A_f = cam(sk::fixed_camera, s.A_f);
  s.A_star = cam(sk::zoomed_camera, s.A_star);
  const Matrix3d R = row_major(node.get(sk::R_r, {0.95692, -0.065563, 0.28284, 0.11725, 0.97846, -0.16989,
                                                  -0.26561, 0.19574, 0.944}));
  if ((R * R.transpose() - Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    node.fail("R_r", "a rotation matrix (row major, orthonormal to 1e-3)");
  s.R_r = geo::nearest_rotation(R);
  const auto t = node.get(sk::t_r_m);
  s.t_r = Vector3d(t[0], t[1], t[2]);
  s.p_f = pairs(node.get(sk::p_f, flat(s.p_f)));
  s.p_star = pairs(node.get(sk::p_star, flat(s.p_star)));
  s.p0 = pairs(node.get(sk::p_initial, flat(s.p0)));
  s.vanish_star = pairs(node.get(sk::vanishing_star, flat(s.vanish_star)));
  s.vanish0 = pairs(node.get(sk::vanishing_initial, flat(s.vanish0)));
  s.desired_depth = node.get(sk::desired_depth_m);
  s.vanishing_weight = node.get(sk::vanishing_weight);
  s.max_plane_tilt = node.get(sk::max_plane_tilt_deg) * M_PI / 180.0;
  return s;
}

SceneFit fit_scene(const ThesisScenario& s) {
  SceneModel m{s, geo::normalise(s.A, s.p_star), geo::normalise(s.A, s.vanish_star)};
  SceneFit fit;
  // Start the rotation from the vanishing-point homography (section 5.3).
  Matrix3d R_init = Matrix3d::Identity();
  const auto vf = geo::fit_homography(s.vanish_star, s.vanish0);
  if (vf.ok()) R_init = geo::nearest_rotation(s.A.inverse() * vf.G * s.A);
  const Vector3d r_init = geo::angle_axis(R_init).vector();
  VectorXd best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (double a : {0.0, 0.5, -0.5}) {
    for (double b : {0.0, 0.5, -0.5}) {
      for (const Vector3d& r0 : {r_init, Vector3d(Vector3d::Zero())}) {
        VectorXd q(8);
        q << a, b, r0, 0, 0, 0;
        q = levenberg_marquardt(m, q);
        const VectorXd r = m.residual(q);
        // Keep only scenes with the target in front of the camera at t = 0.
        const Matrix3d R = geo::rotation_from_vector(q.segment<3>(2));
        // Physical scenes only: the plane faces the goal camera (all depths
        // positive and within a factor 10 of point 1's) and the target is in
        // front of the camera at t = 0.
        bool in_front = true;
        for (const auto& X : m.points(q)) {
          in_front = in_front && X.z() > 0.1 * s.desired_depth && X.z() < 10 * s.desired_depth;
          in_front = in_front && (R * X + q.segment<3>(5)).z() > 0.01;
        }
        in_front = in_front && q.segment<3>(5).norm() < 10 * s.desired_depth;  // camera not at infinity
        if (in_front && r.allFinite() && r.squaredNorm() < best_cost) {
          best_cost = r.squaredNorm();
          best = q;
        }
      }
    }
  }
  if (best.size() == 0) throw std::runtime_error("scene fit: no solution with the target in front of the camera");
  fit.X_d = m.points(best);
  fit.directions_d = m.dirs;
  fit.normal_d = m.normal(best);
  fit.R0 = geo::rotation_from_vector(best.segment<3>(2));
  fit.t0 = best.segment<3>(5);
  const VectorXd r = m.residual(best);
  double sp = 0, sv = 0;
  for (int i = 0; i < 4; ++i) {
    fit.point_residual_px.push_back(r.segment<2>(2 * i).norm());
    sp += r.segment<2>(2 * i).squaredNorm();
  }
  for (int j = 0; j < static_cast<int>(m.dirs.size()); ++j) {
    const double e = r.segment<2>(8 + 2 * j).norm() / s.vanishing_weight;  // report unweighted pixels
    fit.vanishing_residual_px.push_back(e);
    sv += e * e;
  }
  fit.rms_point_px = std::sqrt(sp / 4);
  fit.rms_vanishing_px = std::sqrt(sv / std::max<std::size_t>(1, m.dirs.size()));
  // Zoom consistency of the fixed-camera pixels about the principal point.
  const Vector2d c(s.A_f(0, 2), s.A_f(1, 2));
  double num = 0, den = 0;
  for (std::size_t i = 0; i < s.p_f.size(); ++i) {
    num += (s.p_star[i] - c).dot(s.p_f[i] - c);
    den += (s.p_f[i] - c).squaredNorm();
  }
  fit.zoom_factor_fit = num / den;
  const double k2 = s.A_star(0, 0) / s.A_f(0, 0);
  double e2 = 0, ek = 0;
  for (std::size_t i = 0; i < s.p_f.size(); ++i) {
    e2 += (c + k2 * (s.p_f[i] - c) - s.p_star[i]).squaredNorm();
    ek += (c + fit.zoom_factor_fit * (s.p_f[i] - c) - s.p_star[i]).squaredNorm();
  }
  fit.zoom2_rms_px = std::sqrt(e2 / s.p_f.size());
  fit.zoomk_rms_px = std::sqrt(ek / s.p_f.size());
  return fit;
}

std::string SceneFit::report_json() const {
  std::ostringstream o;
  o.precision(6);
  o << "{\"point_rms_px\": " << rms_point_px << ", \"vanishing_rms_px\": " << rms_vanishing_px
    << ", \"point_residuals_px\": [";
  for (std::size_t i = 0; i < point_residual_px.size(); ++i) o << (i ? ", " : "") << point_residual_px[i];
  o << "], \"vanishing_residuals_px\": [";
  for (std::size_t i = 0; i < vanishing_residual_px.size(); ++i) o << (i ? ", " : "") << vanishing_residual_px[i];
  o << "], \"zoom_factor_fit\": " << zoom_factor_fit << ", \"zoom_x2_rms_px\": " << zoom2_rms_px
    << ", \"zoom_fit_rms_px\": " << zoomk_rms_px << ", \"normal_d\": [" << normal_d.x() << ", " << normal_d.y()
    << ", " << normal_d.z() << "], \"initial_rotation_deg\": " << geo::angle_axis(R0).theta * 180 / M_PI
    << ", \"initial_offset_m\": [" << t0.x() << ", " << t0.y() << ", " << t0.z() << "]}";
  return o.str();
}

HandEyeRig::HandEyeRig(const Matrix3d& R_world_cam, const Vector3d& p_world_cam, const Matrix3d& R_r,
                       const Vector3d& t_r)
    : R_ee_(R_world_cam * R_r), p_ee_(p_world_cam + R_world_cam * t_r), R_r_(R_r), t_r_(t_r) {}

void HandEyeRig::apply(const Twist& robot, double dt) {
  // Midpoint rule for the translation: the end-effector frame turns during dt.
  p_ee_ += R_ee_ * geo::rotation_from_vector(0.5 * dt * robot.w) * robot.v * dt;
  R_ee_ = R_ee_ * geo::rotation_from_vector(dt * robot.w);
}

Matrix3d HandEyeRig::camera_rotation() const { return R_ee_ * R_r_.transpose(); }
Vector3d HandEyeRig::camera_position() const { return p_ee_ - camera_rotation() * t_r_; }
Vector3d HandEyeRig::to_camera(const Vector3d& X) const {
  return camera_rotation().transpose() * (X - camera_position());
}

SimResult simulate(const ThesisScenario& s, const SceneFit& scene, const TbzParams& params, const SimOptions& opt) {
  SimResult res;
  // World frame = F_d. Camera at t = 0: X_F = R0 X_d + t0.
  HandEyeRig rig(scene.R0.transpose(), -scene.R0.transpose() * scene.t0, s.R_r, s.t_r);
  TbzController ctrl(params);
  const std::size_t k = static_cast<std::size_t>(params.translation_point);
  const int steps = static_cast<int>(std::lround(opt.duration / opt.dt));
  const int every = std::max(1, static_cast<int>(std::lround(opt.record_period / opt.dt)));
  for (int i = 0; i <= steps; ++i) {
    TbzMeasurement meas;
    meas.desired_px = s.p_star;
    geo::Points3 Xc;
    for (const auto& X : scene.X_d) Xc.push_back(rig.to_camera(X));
    for (const auto& X : Xc) meas.current_px.push_back(project(s.A, X));
    if (opt.use_vanishing_points) {
      meas.desired_vanishing_px = s.vanish_star;
      for (const auto& D : scene.directions_d)
        meas.current_vanishing_px.push_back(project(s.A, rig.camera_rotation().transpose() * D));
    }
    const TbzOutput out = ctrl.step(meas);
    if (!out.ok()) ++res.summary.failed_steps;

    SimSample smp;
    smp.t = i * opt.dt;
    smp.e_w = geo::angle_axis(rig.camera_rotation().transpose()).vector();  // R_d = F <- F_d
    const Vector3d& X1 = Xc[k];
    const Vector3d& Xd1 = scene.X_d[k];
    smp.e_v = Vector3d(X1.x() / X1.z() - Xd1.x() / Xd1.z(), X1.y() / X1.z() - Xd1.y() / Xd1.z(),
                       std::log(X1.z() / Xd1.z()));
    smp.e_w_hat = out.e_w;
    smp.e_v_hat = out.e_v;
    smp.robot = out.robot;
    smp.px = meas.current_px;
    smp.camera_position = rig.camera_position();
    res.summary.max_linear_velocity = std::max(res.summary.max_linear_velocity, out.robot.v.norm());
    res.summary.max_angular_velocity = std::max(res.summary.max_angular_velocity, out.robot.w.norm());
    if (i == 0) {
      res.summary.initial_rotation_error = smp.e_w.norm();
      res.summary.initial_translation_error = smp.e_v.norm();
    }
    if (i % every == 0 || i == steps) res.samples.push_back(smp);
    if (i == steps) {
      res.summary.final_rotation_error = smp.e_w.norm();
      res.summary.final_translation_error = smp.e_v.norm();
      res.summary.final_position_error_m = rig.camera_position().norm();
      res.summary.final_angle_error_rad = geo::angle_axis(rig.camera_rotation()).theta;
      break;
    }
    rig.apply(out.robot, opt.dt);
  }
  return res;
}

std::string SimSummary::json() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"final_rotation_error\": %.9g, \"final_translation_error\": %.9g, \"initial_rotation_error\": "
                "%.9g, \"initial_translation_error\": %.9g, \"max_linear_velocity\": %.9g, "
                "\"max_angular_velocity\": %.9g}",
                final_rotation_error, final_translation_error, initial_rotation_error, initial_translation_error,
                max_linear_velocity, max_angular_velocity);
  return buf;
}

LogFit log_linear_fit(const std::vector<double>& t, const std::vector<double>& y, double floor) {
  LogFit f;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  for (std::size_t i = 0; i < t.size() && i < y.size(); ++i) {
    if (!(y[i] > floor)) continue;
    const double x = t[i], l = std::log(y[i]);
    sx += x, sy += l, sxx += x * x, sxy += x * l, syy += l * l;
    ++f.n;
  }
  if (f.n < 3) return f;
  const double n = f.n, cxx = sxx - sx * sx / n, cxy = sxy - sx * sy / n, cyy = syy - sy * sy / n;
  if (cxx <= 0 || cyy <= 0) return f;
  f.slope = cxy / cxx;
  f.r2 = cxy * cxy / (cxx * cyy);
  return f;
}

void write_errors_csv(const std::string& path, const SimResult& r) {
  std::ofstream o(path);
  if (!o) throw std::runtime_error("cannot write " + path);
  o << "t,ew_x,ew_y,ew_z,ev_1,ev_2,ev_3,ew_hat_x,ew_hat_y,ew_hat_z,ev_hat_1,ev_hat_2,ev_hat_3,"
       "v_x,v_y,v_z,w_x,w_y,w_z,cam_x,cam_y,cam_z\n";
  o.precision(10);
  for (const auto& s : r.samples) {
    o << s.t;
    for (const Vector3d* v : {&s.e_w, &s.e_v, &s.e_w_hat, &s.e_v_hat, &s.robot.v, &s.robot.w, &s.camera_position})
      o << ',' << v->x() << ',' << v->y() << ',' << v->z();
    o << '\n';
  }
}

void write_features_csv(const std::string& path, const SimResult& r) {
  std::ofstream o(path);
  if (!o) throw std::runtime_error("cannot write " + path);
  const std::size_t n = r.samples.empty() ? 0 : r.samples.front().px.size();
  o << 't';
  for (std::size_t i = 0; i < n; ++i) o << ",u" << i + 1 << ",v" << i + 1;
  o << '\n';
  o.precision(10);
  for (const auto& s : r.samples) {
    o << s.t;
    for (const auto& p : s.px) o << ',' << p.x() << ',' << p.y();
    o << '\n';
  }
}

}  // namespace harvest::control
