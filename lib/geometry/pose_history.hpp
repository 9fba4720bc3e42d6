// Recent robot poses by time, interpolated at an image's capture time
// (linear in position, slerp in orientation).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <optional>

namespace harvest::geometry {

class PoseHistory {
 public:
  explicit PoseHistory(std::size_t capacity = 256) : capacity_(capacity) {}

  // Out-of-order samples are inserted in place; a sample with a time already
  // held replaces it.
  void add(int64_t utime, const Eigen::Isometry3d& pose);

  // Pose at `utime`: interpolated between the samples around it if they are at
  // most max_gap_us apart, else the nearest sample if it is within
  // max_gap_us / 2 (images at the ends of the history); nullopt otherwise.
  std::optional<Eigen::Isometry3d> at(int64_t utime, int64_t max_gap_us) const;

  bool empty() const { return samples_.empty(); }

 private:
  struct Sample {
    int64_t utime;
    Eigen::Vector3d p;
    Eigen::Quaterniond q;
  };
  std::size_t capacity_;
  std::deque<Sample> samples_;
};

}  // namespace harvest::geometry
