// The gripper and its IR proximity sensor as physics: a ray cast along the
// gripper axis, the sensor's response curve and noise, finger closing time,
// capture, detachment by the pull motion, and knocking fruit off.
#pragma once

#include <cstdint>
#include <optional>
#include <random>

#include "sim/scene.hpp"

namespace harvest::sim {

// Distance from `origin` along unit `direction` to the first surface of the
// scene (fruit not yet picked, leaves, branches), or nullopt if nothing is
// nearer than max_range.
std::optional<double> ray_cast(const Scene& scene, const Vec3& origin, const Vec3& direction, double max_range);

// Response of a triangulating IR range sensor on a 10-bit ADC: counts fall
// as gain / (range + offset) beyond the peak range and fold back to zero
// below it, so a very near object reads like a far one (as on the real part).
class IrSensor {
 public:
  IrSensor(const IrSetup& setup, uint64_t seed);
  // Noise-free counts for a true range [m]; nullopt range = nothing in view.
  int ideal_raw(std::optional<double> range) const;
  // Counts with seeded Gaussian noise, clamped to the ADC range.
  int sample(std::optional<double> range);

 private:
  IrSetup setup_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_;
};

enum class GripperPhase : int8_t { kOpen, kClosing, kClosed, kHolding, kOpening };

// Gripper fingers and what they do to the fruit. `tool` is the tool centre
// point pose (z = approach axis); time in seconds of simulation time.
class Gripper {
 public:
  explicit Gripper(const GripperSetup& setup) : setup_(setup) {}

  void close(double t);
  void open(double t);
  // Advances the fingers to time t and applies their effect on the scene.
  // `utime` stamps fruit outcomes.
  void step(double t, int64_t utime, Scene& scene, const Placement& tool);

  GripperPhase phase() const { return phase_; }
  double opening() const { return opening_; }  // 0 closed .. 1 open
  int held_fruit() const { return held_; }      // fruit index, -1 if none

 private:
  void on_closed(int64_t utime, Scene& scene, const Placement& tool);

  GripperSetup setup_;
  GripperPhase phase_ = GripperPhase::kOpen;
  double opening_ = 1.0;
  double last_t_ = 0.0;
  int held_ = -1;
  Vec3 hold_offset_tool_ = Vec3::Zero();  // fruit centre in the tool frame while held
};

}  // namespace harvest::sim
