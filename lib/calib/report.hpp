// What harvest-calibrate writes: the calibration files the processes read
// (config/cameras formats) with the residuals and the date as comments, and
// a PNG report. The same result always gives the same bytes.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calib/solvers.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::calib {

// An OpenCV calibration file (as CameraModel::load reads it) with each line
// of `comment` as a "# " comment after the header; 12 significant digits.
std::string camera_yaml(const geometry::CameraModel& model, const std::string& comment);

// "2026-12-04 05:01:02 UTC" for a time in microseconds since the epoch.
std::string utc_date(int64_t utime);
// "NAME: translation x, y, z mm, rotation A deg about ax, ay, az" (an
// improper frame: its proper twin's rotation).
std::string pose_line(const std::string& name, const Eigen::Isometry3d& t);

// Comment blocks (no leading "# ") describing a result.
std::string intrinsics_comment(const IntrinsicsResult& r);
std::string hand_eye_comment(const HandEyeResult& r);
std::string extrinsics_comment(const ExtrinsicsResult& r);

// The report picture: reprojection error vectors over the image (magnified,
// the 3 x 3 regions lacking corners shaded), then per-view bars (RMS
// reprojection error; with `pose_bars` also the per-view position and
// rotation error of the fixed object).
cv::Mat report_image(const std::string& title, cv::Size image, const std::vector<ViewResult>& views,
                     const std::vector<std::string>& uncovered, bool pose_bars);

}  // namespace harvest::calib
