#include "calib/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace harvest::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

// 12 significant digits, always with a decimal point or exponent (read as a real).
std::string real(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v == 0.0 ? 0.0 : v);  // no "-0"
  std::string s = buf;
  if (s.find_first_of(".en") == std::string::npos) s += ".";
  return s;
}

std::string fixed(double v, int decimals) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string commented(const std::string& comment) {
  std::ostringstream out;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) out << (line.empty() ? "#" : "# " + line) << "\n";
  return out.str();
}

std::string view_range(const std::vector<ViewResult>& views) {
  double lo = 1e9, hi = 0.0;
  for (const auto& v : views) {
    lo = std::min(lo, v.rms_px);
    hi = std::max(hi, v.rms_px);
  }
  return fixed(lo, 3) + ".." + fixed(hi, 3) + " px";
}

std::string worst_view(const std::vector<ViewResult>& views) {
  double pos = 0.0, rot = 0.0;
  for (const auto& v : views) {
    pos = std::max(pos, v.position_error_m);
    rot = std::max(rot, v.rotation_error_rad);
  }
  return fixed(pos * 1000.0, 2) + " mm, " + fixed(rot / kDeg, 3) + " deg";
}

}  // namespace

std::string pose_line(const std::string& name, const Eigen::Isometry3d& t) {
  const Eigen::Vector3d p = t.translation() * 1000.0;
  Eigen::Matrix3d r = t.linear();
  if (r.determinant() < 0) r.col(0) = -r.col(0);  // an improper frame: its proper twin's angle
  const Eigen::AngleAxisd aa(r);
  return name + ": translation " + fixed(p.x(), 2) + ", " + fixed(p.y(), 2) + ", " + fixed(p.z(), 2) +
         " mm, rotation " + fixed(aa.angle() / kDeg, 3) + " deg about " + fixed(aa.axis().x(), 4) + ", " +
         fixed(aa.axis().y(), 4) + ", " + fixed(aa.axis().z(), 4);
}

std::string camera_yaml(const geometry::CameraModel& m, const std::string& comment) {
  std::ostringstream out;
  out << "%YAML:1.0\n---\n" << commented(comment);
  out << "image_width: " << m.width << "\nimage_height: " << m.height << "\n";
  out << "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ " << real(m.fx) << ", "
      << real(m.skew) << ", " << real(m.cx) << ", 0., " << real(m.fy) << ", " << real(m.cy) << ", 0., 0., 1. ]\n";
  out << "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ ";
  for (std::size_t i = 0; i < 5; ++i) out << real(m.dist[i]) << (i < 4 ? ", " : " ]\n");
  return out.str();
}

std::string utc_date(int64_t utime) {
  const std::time_t t = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

std::string intrinsics_comment(const IntrinsicsResult& r) {
  std::ostringstream s;
  s << "RMS reprojection error " << fixed(r.rms_px, 4) << " px over " << r.corners << " corners of " << r.views.size()
    << " views (per view " << view_range(r.views) << ")\n";
  static const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  s << "standard deviations:";
  for (std::size_t i = 0; i < 9; ++i) s << " " << names[i] << " " << fixed(r.std_dev[i], i < 4 ? 3 : 5);
  s << "\nboard tilts span " << fixed(r.tilt_spread_rad / kDeg, 1) << " deg";
  if (r.mirrored) s << "; the board was seen mirrored (an improper camera frame)";
  s << "\nimage regions without corners: ";
  if (r.uncovered.empty()) s << "none";
  for (std::size_t i = 0; i < r.uncovered.size(); ++i) s << (i ? ", " : "") << r.uncovered[i];
  s << "\n";
  return s.str();
}

std::string hand_eye_comment(const HandEyeResult& r) {
  std::ostringstream s;
  s << "Park's answer below; the methods (camera in tool):\n";
  for (const auto& m : r.methods) s << "  " << pose_line(m.name, m.transform) << "\n";
  s << "spread of the methods: " << fixed(r.spread_m * 1000.0, 3) << " mm, " << fixed(r.spread_rad / kDeg, 4)
    << " deg\n";
  s << r.views.size() << " views; the board on its stand through each view, worst off the mean: " << worst_view(r.views)
    << "\nRMS reprojection error through the arm and this answer " << fixed(r.rms_px, 4) << " px\n";
  return s.str();
}

std::string extrinsics_comment(const ExtrinsicsResult& r) {
  std::ostringstream s;
  s << "Shah's answer below; the methods (camera in base):\n";
  for (const auto& m : r.methods) s << "  " << pose_line(m.name, m.transform) << "\n";
  s << "spread of the methods: " << fixed(r.spread_m * 1000.0, 3) << " mm, " << fixed(r.spread_rad / kDeg, 4)
    << " deg\n";
  s << pose_line("board on the tool", r.board_in_tool) << "\n";
  s << r.views.size() << " views; the camera through each view, worst off the mean: " << worst_view(r.views)
    << "\nRMS reprojection error through the arm and this answer " << fixed(r.rms_px, 4) << " px\n";
  if (r.mirrored) s << "the board was seen mirrored: the camera frame is improper (determinant -1)\n";
  return s.str();
}

cv::Mat report_image(const std::string& title, cv::Size image, const std::vector<ViewResult>& views,
                     const std::vector<std::string>& uncovered, bool pose_bars) {
  const double scale = std::max(1.0, 640.0 / image.width);
  const int w = static_cast<int>(image.width * scale), h = static_cast<int>(image.height * scale);
  const int bar_h = 120, margin = 30;
  const int rows = pose_bars ? 3 : 1;
  cv::Mat out(margin + h + rows * (bar_h + margin) + 10, std::max(w, 640), CV_8UC3, cv::Scalar(255, 255, 255));
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  const cv::Scalar black(0, 0, 0), grey(200, 200, 200), red(40, 40, 220), blue(200, 90, 30);
  cv::putText(out, title, {5, 20}, font, 0.5, black, 1, cv::LINE_AA);
  // Image panel: regions without corners shaded, then the error vectors.
  const cv::Rect panel(0, margin, w, h);
  static const char* rnames[] = {"top", "middle", "bottom"};
  static const char* cnames[] = {"left", "centre", "right"};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      const std::string name = r == 1 && c == 1 ? "centre" : std::string(rnames[r]) + " " + cnames[c];
      if (std::find(uncovered.begin(), uncovered.end(), name) != uncovered.end())
        cv::rectangle(out, cv::Rect(c * w / 3, margin + r * h / 3, w / 3, h / 3), cv::Scalar(220, 220, 255),
                      cv::FILLED);
    }
  for (int k = 1; k < 3; ++k) {
    cv::line(out, {k * w / 3, margin}, {k * w / 3, margin + h}, grey);
    cv::line(out, {0, margin + k * h / 3}, {w, margin + k * h / 3}, grey);
  }
  cv::rectangle(out, panel, black);
  double worst = 0.0;
  for (const auto& v : views)
    for (const auto& r : v.residuals) worst = std::max(worst, static_cast<double>(cv::norm(r.error)));
  // The worst error drawn 40 px long.
  const double gain = worst > 0 ? 40.0 / worst : 1.0;
  for (const auto& v : views)
    for (const auto& r : v.residuals) {
      const cv::Point2d p(r.pixel.x * scale, margin + r.pixel.y * scale);
      const cv::Point2d q = p + cv::Point2d(r.error.x, r.error.y) * gain;
      cv::circle(out, p, 1, blue, cv::FILLED, cv::LINE_AA);
      cv::line(out, p, q, red, 1, cv::LINE_AA);
    }
  cv::putText(out, "reprojection errors (found - model), longest " + fixed(worst, 3) + " px drawn 40 px",
              {5, margin + h - 6}, font, 0.4, black, 1, cv::LINE_AA);
  // Per-view bars.
  auto bars = [&](int row, const std::string& label, const std::vector<double>& values, const std::string& unit) {
    const int top = margin + h + margin + row * (bar_h + margin);
    double top_value = 0.0;
    for (const double v : values) top_value = std::max(top_value, v);
    if (top_value <= 0) top_value = 1.0;
    cv::putText(out, label + " per view (max " + fixed(top_value, 3) + " " + unit + ")", {5, top - 8}, font, 0.45,
                black, 1, cv::LINE_AA);
    const int n = static_cast<int>(values.size());
    const double bw = n ? static_cast<double>(out.cols - 10) / n : 0.0;
    for (int i = 0; i < n; ++i) {
      const int bh = static_cast<int>(std::lround(bar_h * values[static_cast<std::size_t>(i)] / top_value));
      cv::rectangle(out, cv::Point(static_cast<int>(5 + i * bw), top + bar_h - bh),
                    cv::Point(static_cast<int>(5 + (i + 1) * bw) - 2, top + bar_h), blue, cv::FILLED);
    }
    cv::line(out, {5, top + bar_h}, {out.cols - 5, top + bar_h}, black);
  };
  std::vector<double> rms, pos, rot;
  for (const auto& v : views) {
    rms.push_back(v.rms_px);
    pos.push_back(v.position_error_m * 1000.0);
    rot.push_back(v.rotation_error_rad / kDeg);
  }
  bars(0, "RMS reprojection error", rms, "px");
  if (pose_bars) {
    bars(1, "position off the mean", pos, "mm");
    bars(2, "rotation off the mean", rot, "deg");
  }
  return out;
}

}  // namespace harvest::calib
