// Fruit identity: per-camera pixel tracks, and hand-camera detections
// associated with fixed-camera fruit by predicted 3D position.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

namespace harvest::vision {

struct PixelObservation {
  double u, v, diameter_px;
};

// Nearest-centroid tracking in one camera: each detection takes the id of the
// closest live track within gate_diameters apparent diameters (greedy,
// closest pairs first, ties by index so results are deterministic); the rest
// start new tracks. A track missing for more than max_missed frames ends.
class PixelTracker {
 public:
  PixelTracker(double gate_diameters, int max_missed, int32_t first_id)
      : gate_(gate_diameters), max_missed_(max_missed), next_id_(first_id) {}
  std::vector<int32_t> update(const std::vector<PixelObservation>& detections);
  bool alive(int32_t id) const;

 private:
  struct Track {
    int32_t id;
    PixelObservation last;
    int missed = 0;
  };
  double gate_;
  int max_missed_;
  int32_t next_id_;
  std::vector<Track> tracks_;
};

struct Estimate3d {
  Eigen::Vector3d position;
  Eigen::Matrix3d covariance;
};

// Squared Mahalanobis distance of a - b under covariance ca + cb.
double mahalanobis2(const Estimate3d& a, const Estimate3d& b);

// Assigns hand tracks to known fruit (global ids). A hand track that was
// associated before keeps its fruit while the track lives (the estimates
// drift apart as the hand camera's close view refines the fixed camera's);
// new tracks take the fruit with the smallest Mahalanobis distance within
// gate_chi2, closest pairs first, one track per fruit. Returns, per
// detection, the global id or nullopt.
class HandAssociator {
 public:
  explicit HandAssociator(double gate_chi2) : gate_chi2_(gate_chi2) {}
  std::vector<std::optional<int32_t>> associate(const std::vector<int32_t>& hand_track_ids,
                                                const std::vector<Estimate3d>& hand_estimates,
                                                const std::map<int32_t, Estimate3d>& fruit);
  // Forget links of hand tracks that ended.
  void prune(const PixelTracker& hand_tracker);

 private:
  double gate_chi2_;
  std::map<int32_t, int32_t> link_;  // hand track id -> global fruit id
};

}  // namespace harvest::vision
