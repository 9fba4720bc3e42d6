#include "calib/solvers.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <sstream>

namespace harvest::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The left-right mirror of a camera frame (x -> -x).
const Eigen::Matrix3d kMirror = Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();

std::string fixed(double v, int decimals) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(decimals);
  s << v;
  return s.str();
}

std::vector<cv::Point3f> object_points(const BoardView& v, const cv::Ptr<cv::aruco::CharucoBoard>& board) {
  std::vector<cv::Point3f> p;
  p.reserve(v.ids.size());
  for (const int id : v.ids) p.push_back(board->chessboardCorners.at(static_cast<std::size_t>(id)));
  return p;
}

std::vector<cv::Point2f> proper_pixels(const BoardView& v) {
  std::vector<cv::Point2f> p;
  p.reserve(v.corners.size());
  for (const auto& c : v.corners) p.push_back(proper_pixel(v, c));
  return p;
}

cv::Mat camera_matrix(const geometry::CameraModel& m) {
  return (cv::Mat_<double>(3, 3) << m.fx, m.skew, m.cx, 0, m.fy, m.cy, 0, 0, 1);
}
cv::Mat distortion(const geometry::CameraModel& m) {
  return (cv::Mat_<double>(1, 5) << m.dist[0], m.dist[1], m.dist[2], m.dist[3], m.dist[4]);
}

Eigen::Isometry3d isometry(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d re;
  cv::cv2eigen(r, re);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = re;
  t.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return t;
}

Eigen::Isometry3d from_matrices(const cv::Mat& r, const cv::Mat& t) {
  Eigen::Matrix3d re;
  cv::cv2eigen(r, re);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = re;
  out.translation() = Eigen::Vector3d(t.at<double>(0), t.at<double>(1), t.at<double>(2));
  return out;
}

// Into new matrices: eigen2cv would write through a Mat still shared with a vector.
void to_cv(const Eigen::Isometry3d& t, cv::Mat& r, cv::Mat& tv) {
  const Eigen::Matrix3d rot = t.linear();
  r.release();
  cv::eigen2cv(rot, r);
  tv = (cv::Mat_<double>(3, 1) << t.translation().x(), t.translation().y(), t.translation().z());
}

// Reprojection residuals of a view at a board pose in the (proper) camera frame.
ViewResult reproject(const BoardView& v, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                     const geometry::CameraModel& proper_camera, const Eigen::Isometry3d& board_in_cam) {
  cv::Mat r, t, rvec;
  to_cv(board_in_cam, r, t);
  cv::Rodrigues(r, rvec);
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object_points(v, board), rvec, t, camera_matrix(proper_camera), distortion(proper_camera),
                    projected);
  ViewResult out;
  out.utime = v.utime;
  double sum = 0.0;
  for (std::size_t k = 0; k < projected.size(); ++k) {
    cv::Point2f e = proper_pixel(v, v.corners[k]) - projected[k];
    sum += e.dot(e);
    if (v.mirrored) e.x = -e.x;  // back in the frame's own pixels
    out.residuals.push_back({v.corners[k], e});
  }
  out.rms_px = projected.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(projected.size()));
  return out;
}

double overall_rms(const std::vector<ViewResult>& views) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& v : views)
    for (const auto& r : v.residuals) {
      sum += r.error.dot(r.error);
      ++n;
    }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

// Chordal mean of rotations (projected back onto SO(3)) and mean position.
Eigen::Isometry3d mean_pose(const std::vector<Eigen::Isometry3d>& poses) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (const auto& t : poses) {
    sum += t.linear();
    p += t.translation();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  out.translation() = p / static_cast<double>(poses.size());
  return out;
}

double angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

void check_common(const std::vector<BoardView>& views, int min_views, const char* what) {
  if (views.empty())
    throw CalibrationError(std::string(what) +
                           ": the board was not found in any frame (check the channel, the board's squares, "
                           "dictionary and sizes, and that the whole board is in view and lit)");
  if (static_cast<int>(views.size()) < min_views)
    throw CalibrationError(std::string(what) + ": " + std::to_string(views.size()) + " usable views, need at least " +
                           std::to_string(min_views) + " (more poses, each showing the board sharply)");
  for (const auto& v : views) {
    if (v.image_size != views.front().image_size)
      throw CalibrationError(std::string(what) + ": frames of different sizes on one channel");
    if (v.mirrored != views.front().mirrored)
      throw CalibrationError(std::string(what) + ": some views show the board mirrored and some not");
  }
}

}  // namespace

geometry::CameraModel mirror_model(const geometry::CameraModel& m) {
  geometry::CameraModel out = m;
  out.cx = (m.width - 1) - m.cx;
  out.skew = -m.skew;
  out.dist[3] = -m.dist[3];
  return out;
}

IntrinsicsResult solve_intrinsics(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const IntrinsicsOptions& options) {
  check_common(views, options.min_views, "intrinsics");
  const cv::Size size = views.front().image_size;
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  IntrinsicsResult res;
  res.mirrored = views.front().mirrored;
  for (const auto& v : views) {
    obj.push_back(object_points(v, board));
    img.push_back(proper_pixels(v));
    res.corners += static_cast<int>(v.ids.size());
  }
  cv::Mat k, d, std_intr, std_extr, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  // OpenCV's default model: fx, fy, cx, cy, k1 k2 p1 p2 k3, no skew.
  cv::calibrateCamera(obj, img, size, k, d, rvecs, tvecs, std_intr, std_extr, per_view, 0,
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, DBL_EPSILON));
  geometry::CameraModel proper;
  proper.width = size.width;
  proper.height = size.height;
  proper.fx = k.at<double>(0, 0);
  proper.fy = k.at<double>(1, 1);
  proper.cx = k.at<double>(0, 2);
  proper.cy = k.at<double>(1, 2);
  for (int i = 0; i < 5; ++i) proper.dist[static_cast<std::size_t>(i)] = d.at<double>(i);
  res.model = res.mirrored ? mirror_model(proper) : proper;
  for (int i = 0; i < 9; ++i) res.std_dev[static_cast<std::size_t>(i)] = std_intr.at<double>(i);

  std::vector<Eigen::Vector3d> normals;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const Eigen::Isometry3d pose = isometry(rvecs[i], tvecs[i]);
    normals.push_back(pose.linear().col(2));
    res.views.push_back(reproject(views[i], board, proper, pose));
  }
  res.rms_px = overall_rms(res.views);
  for (std::size_t i = 0; i < normals.size(); ++i)
    for (std::size_t j = i + 1; j < normals.size(); ++j)
      res.tilt_spread_rad = std::max(res.tilt_spread_rad, std::acos(std::clamp(normals[i].dot(normals[j]), -1.0, 1.0)));

  // Which ninths of the image no corner reached.
  static const char* rows[] = {"top", "middle", "bottom"};
  static const char* cols[] = {"left", "centre", "right"};
  int hits[3][3] = {};
  for (const auto& v : views)
    for (const auto& c : v.corners) {
      const int cx = std::clamp(static_cast<int>(3 * c.x / size.width), 0, 2);
      const int cy = std::clamp(static_cast<int>(3 * c.y / size.height), 0, 2);
      ++hits[cy][cx];
    }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (hits[r][c] < options.min_corners_per_region)
        res.uncovered.push_back(r == 1 && c == 1 ? std::string("centre") : std::string(rows[r]) + " " + cols[c]);

  if (res.tilt_spread_rad < options.min_tilt_spread_rad)
    throw CalibrationError("intrinsics: every view shows the board at nearly the same angle (they differ by " +
                           fixed(res.tilt_spread_rad / kDeg, 1) + " deg, need " +
                           fixed(options.min_tilt_spread_rad / kDeg, 1) +
                           "): the focal length cannot be told from the distance; tilt the board 20-40 deg "
                           "about different axes");
  const double rel_fx = res.std_dev[0] / proper.fx, rel_fy = res.std_dev[1] / proper.fy;
  if (!(std::max(rel_fx, rel_fy) <= options.max_focal_std))
    throw CalibrationError("intrinsics: the focal length is uncertain to " + fixed(100 * std::max(rel_fx, rel_fy), 2) +
                           " % (allowed " + fixed(100 * options.max_focal_std, 2) +
                           " %): add views with the board tilted and nearer the image corners");
  return res;
}

Eigen::Isometry3d board_in_camera(const BoardView& v, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const geometry::CameraModel& camera, ViewResult* result) {
  const geometry::CameraModel proper = v.mirrored ? mirror_model(camera) : camera;
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object_points(v, board), proper_pixels(v), camera_matrix(proper), distortion(proper), rvec, tvec,
                    false, cv::SOLVEPNP_ITERATIVE))
    throw CalibrationError("board pose: solvePnP failed on the view at utime " + std::to_string(v.utime));
  const Eigen::Isometry3d pose = isometry(rvec, tvec);
  if (result) *result = reproject(v, board, proper, pose);
  return pose;
}

void check_rotation_diversity(const std::vector<Eigen::Isometry3d>& poses, const PoseOptions& options) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  double largest = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i)
    for (std::size_t j = i + 1; j < poses.size(); ++j) {
      const Eigen::AngleAxisd rel(poses[i].linear().transpose() * poses[j].linear());
      largest = std::max(largest, rel.angle());
      if (rel.angle() < 2.0 * kDeg) continue;
      scatter += rel.axis() * rel.axis().transpose();
    }
  if (largest < options.min_rotation_rad)
    throw CalibrationError("the tool turns by at most " + fixed(largest / kDeg, 1) + " deg between views (need " +
                           fixed(options.min_rotation_rad / kDeg, 1) +
                           "): with rotations this small the camera's position on the tool is not determined");
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);  // ascending eigenvalues
  const double spread = std::atan(std::sqrt(std::max(0.0, eig.eigenvalues()(1)) / eig.eigenvalues()(2)));
  if (spread < options.min_axis_spread_rad) {
    const Eigen::Vector3d axis = eig.eigenvectors().col(2);
    throw CalibrationError("every rotation of the tool between views turns about one axis (tool frame " +
                           fixed(axis.x(), 2) + ", " + fixed(axis.y(), 2) + ", " + fixed(axis.z(), 2) + "; spread " +
                           fixed(spread / kDeg, 1) +
                           " deg): the answer is undetermined along it; add poses turned about another axis");
  }
}

HandEyeResult solve_hand_eye(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                             const geometry::CameraModel& camera, const PoseOptions& options) {
  check_common(views, options.min_views, "hand-eye");
  std::vector<Eigen::Isometry3d> tools, boards;
  std::vector<cv::Mat> r_g2b, t_g2b, r_t2c, t_t2c;
  for (const auto& v : views) {
    if (!v.tool_pose) throw CalibrationError("hand-eye: a view without the arm's pose");
    tools.push_back(*v.tool_pose);
    boards.push_back(board_in_camera(v, board, camera));
    cv::Mat r, t;
    to_cv(tools.back(), r, t);
    r_g2b.push_back(r);
    t_g2b.push_back(t);
    to_cv(boards.back(), r, t);
    r_t2c.push_back(r);
    t_t2c.push_back(t);
  }
  check_rotation_diversity(tools, options);
  HandEyeResult res;
  // Solved in the proper (possibly mirrored) camera frame; the mirror is put back at the end.
  const Eigen::Matrix3d mirror = views.front().mirrored ? kMirror : Eigen::Matrix3d::Identity();
  Eigen::Isometry3d park;
  for (const auto& [name, method] :
       {std::pair{"Tsai", cv::CALIB_HAND_EYE_TSAI}, std::pair{"Park", cv::CALIB_HAND_EYE_PARK},
        std::pair{"Daniilidis", cv::CALIB_HAND_EYE_DANIILIDIS}}) {
    cv::Mat r, t;
    cv::calibrateHandEye(r_g2b, t_g2b, r_t2c, t_t2c, r, t, method);
    const Eigen::Isometry3d x = from_matrices(r, t);
    if (std::string(name) == "Park") park = x;
    res.methods.push_back({name, x});
  }
  for (auto& m : res.methods) {
    res.spread_m = std::max(res.spread_m, (m.transform.translation() - park.translation()).norm());
    res.spread_rad = std::max(res.spread_rad, angle_between(m.transform.linear(), park.linear()));
    m.transform.linear() = m.transform.linear() * mirror;
  }
  // The board in the base frame seen through each view: the spread is the residual.
  std::vector<Eigen::Isometry3d> in_base;
  for (std::size_t i = 0; i < views.size(); ++i) in_base.push_back(tools[i] * park * boards[i]);
  const Eigen::Isometry3d board_base = mean_pose(in_base);
  const geometry::CameraModel proper = views.front().mirrored ? mirror_model(camera) : camera;
  for (std::size_t i = 0; i < views.size(); ++i) {
    ViewResult vr = reproject(views[i], board, proper, (tools[i] * park).inverse() * board_base);
    vr.position_error_m = (in_base[i].translation() - board_base.translation()).norm();
    vr.rotation_error_rad = angle_between(in_base[i].linear(), board_base.linear());
    res.views.push_back(std::move(vr));
  }
  res.rms_px = overall_rms(res.views);
  res.camera_in_tool = park;
  res.camera_in_tool.linear() = park.linear() * mirror;
  return res;
}

ExtrinsicsResult solve_extrinsics(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const geometry::CameraModel& camera, const PoseOptions& options) {
  check_common(views, options.min_views, "extrinsics");
  // cv::calibrateRobotWorldHandEye solves cTw wTb = cTg gTb. With the camera
  // fixed and the board on the tool: c = camera, w = board, b = tool,
  // g = robot base, so gTb is the tool pose in the base frame, wTb the tool
  // in the board's frame and cTg the base in the camera's.
  std::vector<Eigen::Isometry3d> tools, boards;
  std::vector<cv::Mat> r_w2c, t_w2c, r_b2g, t_b2g;
  for (const auto& v : views) {
    if (!v.tool_pose) throw CalibrationError("extrinsics: a view without the arm's pose");
    tools.push_back(*v.tool_pose);
    boards.push_back(board_in_camera(v, board, camera));
    cv::Mat r, t;
    to_cv(boards.back(), r, t);
    r_w2c.push_back(r);
    t_w2c.push_back(t);
    to_cv(tools.back(), r, t);
    r_b2g.push_back(r);
    t_b2g.push_back(t);
  }
  check_rotation_diversity(tools, options);
  ExtrinsicsResult res;
  res.mirrored = views.front().mirrored;
  const Eigen::Matrix3d mirror = res.mirrored ? kMirror : Eigen::Matrix3d::Identity();
  Eigen::Isometry3d shah_base_in_cam, shah_tool_in_board;
  for (const auto& [name, method] :
       {std::pair{"Shah", cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH}, std::pair{"Li", cv::CALIB_ROBOT_WORLD_HAND_EYE_LI}}) {
    cv::Mat r_b2w, t_b2w, r_g2c, t_g2c;
    cv::calibrateRobotWorldHandEye(r_w2c, t_w2c, r_b2g, t_b2g, r_b2w, t_b2w, r_g2c, t_g2c, method);
    const Eigen::Isometry3d base_in_cam = from_matrices(r_g2c, t_g2c);
    if (std::string(name) == "Shah") {
      shah_base_in_cam = base_in_cam;
      shah_tool_in_board = from_matrices(r_b2w, t_b2w);
    }
    res.methods.push_back({name, base_in_cam.inverse()});
  }
  const Eigen::Isometry3d cam_in_base = shah_base_in_cam.inverse();
  for (auto& m : res.methods) {
    res.spread_m = std::max(res.spread_m, (m.transform.translation() - cam_in_base.translation()).norm());
    res.spread_rad = std::max(res.spread_rad, angle_between(m.transform.linear(), cam_in_base.linear()));
    m.transform.linear() = m.transform.linear() * mirror;
  }
  res.board_in_tool = shah_tool_in_board.inverse();
  // The camera in the base frame seen through each view.
  std::vector<Eigen::Isometry3d> per_view;
  for (std::size_t i = 0; i < views.size(); ++i) per_view.push_back(tools[i] * res.board_in_tool * boards[i].inverse());
  const Eigen::Isometry3d mean = mean_pose(per_view);
  const geometry::CameraModel proper = res.mirrored ? mirror_model(camera) : camera;
  for (std::size_t i = 0; i < views.size(); ++i) {
    ViewResult vr = reproject(views[i], board, proper, shah_base_in_cam * tools[i] * res.board_in_tool);
    vr.position_error_m = (per_view[i].translation() - mean.translation()).norm();
    vr.rotation_error_rad = angle_between(per_view[i].linear(), mean.linear());
    res.views.push_back(std::move(vr));
  }
  res.rms_px = overall_rms(res.views);
  res.camera_in_base = cam_in_base;
  res.camera_in_base.linear() = cam_in_base.linear() * mirror;
  return res;
}

double worst_undistortion_difference(const geometry::CameraModel& a, const geometry::CameraModel& b, int step) {
  const Eigen::Matrix3d ka = a.matrix(), kb = b.matrix();
  double worst = 0.0;
  for (int y = 0; y < a.height; y += step)
    for (int x = 0; x < a.width; x += step) {
      const Eigen::Vector2d px(x, y);
      const Eigen::Vector3d ua = ka * a.undistort_to_normalized(px).homogeneous();
      const Eigen::Vector3d ub = kb * b.undistort_to_normalized(px).homogeneous();
      worst = std::max(worst, (ua.head<2>() - ub.head<2>()).norm());
    }
  return worst;
}

}  // namespace harvest::calib
