// The fruit detector scored against the simulator's truth (harvest-vision-eval,
// docs/perception.md "Simulated tree"): per true fruit at least min_visible
// visible, how many detections lie on it and how far their diameter is from
// the fruit's true apparent diameter; the depth error of eq. 6-11 by true
// depth. The caller gives the TRUE camera (the simulator's, not the
// software's calibration).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "geometry/camera_model.hpp"
#include "harvest/sim_truth_t.hpp"
#include "runtime/log_io.hpp"
#include "vision/detector_node.hpp"

namespace harvest::vision {

struct TruthEvalOptions {
  std::string camera = "fixed";          // fixed | hand (pose from SIM_TRUTH; every fruit counts as fully visible)
  int first = 0, count = 60, every = 1;  // frames scored: index first, first + every, ... count of them
  double min_visible = 0.5;              // score fruit at least this visible
  int verbose_frames = 0;                // per-fruit lines for this many frames
  std::filesystem::path overlay_dir;     // frames with detections and truth drawn; empty: none
  std::vector<int> crop;                 // with overlay_dir: also this sensor rectangle x y w h, 3x
};

// The true camera: intrinsics and distortion at sensor resolution, and the
// fixed camera's placement p_base = rotation * p_camera + position.
struct TrueCamera {
  geometry::CameraModel model;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

// A true fruit as the camera sees it.
struct TruthFruit {
  Eigen::Vector2d centre;  // sensor px
  double diameter_px = 0;  // mean of the silhouette's x and y extents
  double depth_m = 0;
  double visible = 0;
  int id = 0;
};

// The fruit on the tree in front of the camera (placed at rotation,
// position) and near its sensor: each sphere's limb circle projected.
// `visible` is the simulator's fixed-camera visibility, or 1 if
// every_fruit_visible (the hand camera has none).
std::vector<TruthFruit> project_truth(const sim_truth_t& truth, const geometry::CameraModel& camera,
                                      const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position,
                                      bool every_fruit_visible);

// A detection in sensor pixels.
struct SensorDetection {
  Eigen::Vector2d centre;
  double diameter_px = 0;
};

// The fruit a detection belongs to: the one whose disc holds its centre,
// nearest relative to its radius; -1 if none.
int fruit_of(const SensorDetection& d, const std::vector<TruthFruit>& fruits);

// The tallies over the scored frames.
class TruthEvaluation {
 public:
  // f_mean: the software's mean focal length [px], d_o: its statistical fruit diameter [m].
  TruthEvaluation(double min_visible, double f_mean, double d_o);

  // Each detection goes to the fruit whose disc holds its centre, nearest
  // relative to its radius. Returns, per fruit, the diameters of the
  // detections on it.
  std::vector<std::vector<double>> add_frame(const std::vector<SensorDetection>& detections,
                                             const std::vector<TruthFruit>& fruits);

  // The summary harvest-vision-eval prints.
  void report(std::ostream& out, int scored_frames, double detect_ms) const;

  int fruit_scored() const;
  int unmatched() const { return unmatched_; }

 private:
  double min_visible_, f_mean_, d_o_;
  std::map<int, int> histogram_;  // detections per scored fruit -> fruit
  std::vector<double> diam_err_best_, diam_err_all_;
  std::map<int, std::vector<double>> depth_err_bins_;      // 100 mm bins of true depth -> error [mm]
  std::map<int, std::vector<double>> depth_err_largest_;   // the same, largest detection per fruit only
  std::map<int, std::vector<double>> centre_err_largest_;  // its centre's distance from the true one, % of diameter
  int unmatched_ = 0, detections_total_ = 0;
};

// The whole tool over a log's frames on CAMERA_FIXED (or CAMERA_HAND) after
// the first SIM_TRUTH; the summary and per-frame lines on `out`. Returns 0,
// or 1 with the reason on `err` if an overlay cannot be written.
int run_truth_evaluation(const std::vector<rt::LogRecord>& log, const DetectorNodeConfig& config,
                         const TrueCamera& truth_camera, const TruthEvalOptions& options, std::ostream& out,
                         std::ostream& err);

}  // namespace harvest::vision
