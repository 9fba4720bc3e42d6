// A fruit swaying in the wind, from where the camera-in-hand saw it: a least-
// squares fit of a sinusoid per axis (one frequency for all three, a drift
// term taking up what the moving camera's depth error adds), and when to
// close the gripper on it so that the fruit is predicted on the gripper axis
// as the jaws meet (the hand camera is blind for the last centimetres and
// the close takes 0.6 s: a fruit moving at 4-15 cm/s goes on by 2-9 cm).
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "servo/servo_config.hpp"

namespace harvest::servo {

// p(t) = centre + drift (t - t_ref) + cos_part cos(w (t - t_ref)) + sin_part sin(w (t - t_ref)),
// t_ref the newest sample's time, w = 2 pi frequency_hz.
struct SwayFit {
  bool swaying = false;                                // false: "still" (or too little seen to tell): nothing changes
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();    // [m] middle of the sway at t_ref
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();     // [m/s]
  Eigen::Vector3d cos_part = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d sin_part = Eigen::Vector3d::Zero();  // [m]
  double frequency_hz = 0.0;
  double amplitude = 0.0;     // [m] sqrt(|cos_part|^2 + |sin_part|^2): the peak for a sway along one line
  double phase = 0.0;         // [rad] at t_ref, of the sway along its main direction
  double confidence = 0.0;    // share of the variance about the drift the sinusoid explains, 0..1
  double rms_residual = 0.0;  // [m]
  int samples = 0;
  double span_s = 0.0;             // newest minus oldest sample time
  double t_ref = 0.0;              // [s]
  bool learned_frequency = false;  // the frequency is the one learned on earlier fruit

  // Predicted position at t [s]; the drift is not extrapolated (it is the
  // camera's, not the fruit's).
  Eigen::Vector3d at(double t) const;
};

class SwayEstimator {
 public:
  explicit SwayEstimator(ServoConfig::Sway params) : p_(std::move(params)) {}

  // A position of the fruit [m, base frame] seen at t [s]; samples older than
  // the window before the newest are dropped.
  void add(double t, const Eigen::Vector3d& position);
  // A new fruit: its samples are forgotten, but not what they said about the
  // frequency. The wind and the stems are the tree's: every fruit that moved
  // adds its fit's unexplained share at each frequency it was seen long
  // enough for (0.4 periods) to a sum; the frequency with the least mean
  // share among those at least learn_fruit fruit were seen for is the tree's, and later fruit are fitted at it (their
  // amplitude, phase and centre their own). One fruit seen briefly through a noisy camera fits a wrong frequency as
  // well as the right one; over several the right one wins.
  void reset();
  int size() const { return static_cast<int>(samples_.size()); }
  // How far the positions kept lie from their mean (rms) [m]; 0 with fewer
  // than min_samples. A still fruit seen under IR guidance spreads by the
  // pixel noise and the depth error's sideways share, 1-2 mm; a swaying one
  // by its sway across the axis. Unlike the fit it needs no whole period.
  double spread() const;
  // The same over the positions seen at or after t [s]; nullopt with fewer than min_samples of them.
  std::optional<double> spread_since(double t) const;
  std::optional<double> learned_hz() const;

  SwayFit fit() const;

 private:
  // The least-squares fit at one frequency (residual in rms_residual).
  SwayFit fit_at(double hz) const;
  int grid_size() const;
  double grid_hz(int i) const { return p_.min_frequency_hz + i * p_.frequency_step_hz; }

  ServoConfig::Sway p_;
  std::deque<std::pair<double, Eigen::Vector3d>> samples_;
  std::vector<double> unexplained_;  // per grid frequency, summed over the fruit that moved ...
  std::vector<int> fruit_seen_;      // ... and were seen long enough to tell it from a drift
  bool ignore_learned_ = false;      // reset(): the fruit's own fit
};

// Whether to close now, the IR saying the fruit is inside: a still fruit at
// once (as without wind), and one whose fitted sway centre lies more than
// max_centre_offset off the gripper axis (the fit disagrees with the IR and
// the centring); a swaying one when its predicted position at the
// end of the close (close_delay from now) lies within close_tolerance of the
// gripper axis, or is as near as it will come before max_wait runs out (or
// within the next period); after max_wait of waiting, at once. `step_s`:
// the control period (the nearest moment within one step is now).
struct CloseDecision {
  bool close = true;
  double offset = 0.0;     // [m] predicted distance of the fruit from the gripper axis at the end of a close begun now
  double best_wait = 0.0;  // [s] waiting this long would bring it nearest
  double best_offset = 0.0;  // [m] ... this near
};
CloseDecision close_decision(const SwayFit& fit, const Eigen::Isometry3d& tool, double now_s, double waited_s,
                             double step_s, const ServoConfig::Sway& p);

}  // namespace harvest::servo
