#include "geometry/camera_model.hpp"

#include <cmath>
#include <opencv2/core.hpp>
#include <stdexcept>

namespace harvest::geometry {

namespace {

[[noreturn]] void load_error(const std::filesystem::path& file, const std::string& what) {
  throw std::runtime_error("camera calibration " + file.string() + ": " + what);
}

cv::Mat read_matrix(const cv::FileStorage& fs, const std::filesystem::path& file, const char* key) {
  const cv::FileNode node = fs[key];
  if (node.empty()) load_error(file, std::string("missing '") + key + "'");
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception& e) {
    load_error(file, std::string("'") + key + "' is not an OpenCV matrix: " + e.what());
  }
  if (m.empty()) load_error(file, std::string("'") + key + "' is not an OpenCV matrix (!!opencv-matrix)");
  m.convertTo(m, CV_64F);
  return m;
}

int read_size(const cv::FileStorage& fs, const std::filesystem::path& file, const char* key) {
  const cv::FileNode node = fs[key];
  if (node.empty() || !node.isInt()) load_error(file, std::string("missing or non-integer '") + key + "'");
  return static_cast<int>(node);
}

}  // namespace

CameraModel CameraModel::load(const std::filesystem::path& file) {
  if (!std::filesystem::is_regular_file(file)) load_error(file, "no such file");
  cv::FileStorage fs;
  try {
    fs.open(file.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    load_error(file, std::string("cannot parse: ") + e.what());
  }
  if (!fs.isOpened()) load_error(file, "cannot parse (expected OpenCV FileStorage YAML)");

  const cv::Mat a = read_matrix(fs, file, "camera_matrix");
  if (a.rows != 3 || a.cols != 3) load_error(file, "camera_matrix must be 3x3");
  if (a.at<double>(1, 0) != 0.0 || a.at<double>(2, 0) != 0.0 || a.at<double>(2, 1) != 0.0 || a.at<double>(2, 2) != 1.0)
    load_error(file, "camera_matrix must be upper triangular with A(2,2) = 1");
  const cv::Mat d = read_matrix(fs, file, "distortion_coefficients");
  if (d.total() != 4 && d.total() != 5)
    load_error(file,
               "distortion_coefficients must have 4 or 5 values (k1 k2 p1 p2 [k3]), got " + std::to_string(d.total()));

  CameraModel c;
  c.fx = a.at<double>(0, 0);
  c.skew = a.at<double>(0, 1);
  c.cx = a.at<double>(0, 2);
  c.fy = a.at<double>(1, 1);
  c.cy = a.at<double>(1, 2);
  for (std::size_t i = 0; i < d.total(); ++i) c.dist[i] = d.at<double>(static_cast<int>(i));
  c.width = read_size(fs, file, "image_width");
  c.height = read_size(fs, file, "image_height");
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    load_error(file, e.what());
  }
  return c;
}

CameraModel CameraModel::from_config(const config::Node& n, const config::Key<config::Path>& key) {
  return from_config(n, key, std::string(key.fallback));
}

CameraModel CameraModel::from_config(const config::Node& n, const config::Key<config::Path>& key_decl,
                                     const std::string& derived_fallback) {
  const std::string key = key_decl.name;
  const auto path = key_decl.required ? n.file_path(key) : n.file_path(key, derived_fallback);
  try {
    return load(path);
  } catch (const std::exception& e) {
    n.fail(key, std::string("a readable camera calibration (") + e.what() + ")");
  }
}

void CameraModel::save(const std::filesystem::path& file) const {
  cv::FileStorage fs(file.string(), cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error("cannot write camera calibration " + file.string());
  fs << "image_width" << width << "image_height" << height;
  const cv::Matx33d a(fx, skew, cx, 0, fy, cy, 0, 0, 1);
  fs << "camera_matrix" << cv::Mat(a);
  fs << "distortion_coefficients" << cv::Mat(cv::Matx<double, 1, 5>(dist[0], dist[1], dist[2], dist[3], dist[4]));
}

CameraModel CameraModel::from_thesis(double l1, double l2, double phi, double u0, double v0, int width, int height,
                                     const std::array<double, 5>& dist) {
  CameraModel c;
  c.fx = l1;
  c.skew = -l1 * std::cos(phi) / std::sin(phi);
  c.fy = l2 / std::sin(phi);
  c.cx = u0;
  c.cy = v0;
  c.dist = dist;
  c.width = width;
  c.height = height;
  c.validate();
  return c;
}

void CameraModel::validate() const {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!(finite(fx) && fx > 0 && finite(fy) && fy > 0))
    throw std::invalid_argument("focal lengths must be positive, got fx=" + std::to_string(fx) +
                                " fy=" + std::to_string(fy));
  if (!finite(skew) || !finite(cx) || !finite(cy)) throw std::invalid_argument("non-finite camera matrix entry");
  for (double k : dist)
    if (!finite(k)) throw std::invalid_argument("non-finite distortion coefficient");
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("image size must be positive, got " + std::to_string(width) + "x" +
                                std::to_string(height));
}

Eigen::Matrix3d CameraModel::matrix() const {
  Eigen::Matrix3d a;
  a << fx, skew, cx, 0, fy, cy, 0, 0, 1;
  return a;
}

bool CameraModel::has_distortion() const {
  for (double k : dist)
    if (k != 0.0) return true;
  return false;
}

Eigen::Vector2d CameraModel::distort(const Eigen::Vector2d& m) const {
  const auto [k1, k2, p1, p2, k3] = dist;
  const double x = m.x(), y = m.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

// Appendix D: m = (md - tangential(m)) / radial(m), iterated from m = md.
Eigen::Vector2d CameraModel::undistort(const Eigen::Vector2d& md, int iterations) const {
  const auto [k1, k2, p1, p2, k3] = dist;
  double x = md.x(), y = md.y();
  for (int i = 0; i < iterations; ++i) {
    const double r2 = x * x + y * y;
    const double inv_radial = 1 / (1 + r2 * (k1 + r2 * (k2 + r2 * k3)));
    const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = (md.x() - dx) * inv_radial;
    y = (md.y() - dy) * inv_radial;
  }
  return {x, y};
}

Eigen::Vector2d CameraModel::normalized_to_pixel(const Eigen::Vector2d& m) const {
  const Eigen::Vector2d d = distort(m);
  return {fx * d.x() + skew * d.y() + cx, fy * d.y() + cy};
}

Eigen::Vector2d CameraModel::project(const Eigen::Vector3d& p_cam) const {
  return normalized_to_pixel(p_cam.head<2>() / p_cam.z());
}

Eigen::Vector2d CameraModel::undistort_to_normalized(const Eigen::Vector2d& px, int iterations) const {
  const double yd = (px.y() - cy) / fy;
  const double xd = (px.x() - cx - skew * yd) / fx;
  return undistort({xd, yd}, iterations);
}

Eigen::Vector3d CameraModel::back_project(const Eigen::Vector2d& px, double depth) const {
  const Eigen::Vector2d m = undistort_to_normalized(px);
  return {m.x() * depth, m.y() * depth, depth};
}

// Pixel centres at integer coordinates, as cv::resize: u' + 0.5 = (u + 0.5 - x0) * s.
CameraModel CameraModel::zoomed(double roi_x, double roi_y, double roi_w, double roi_h, int out_width,
                                int out_height) const {
  if (!(roi_w > 0 && roi_h > 0 && out_width > 0 && out_height > 0))
    throw std::invalid_argument("zoom region and output size must be positive");
  const double sx = out_width / roi_w, sy = out_height / roi_h;
  CameraModel c = *this;
  c.fx = fx * sx;
  c.skew = skew * sx;
  c.cx = (cx + 0.5 - roi_x) * sx - 0.5;
  c.fy = fy * sy;
  c.cy = (cy + 0.5 - roi_y) * sy - 0.5;
  c.width = out_width;
  c.height = out_height;
  return c;
}

}  // namespace harvest::geometry
