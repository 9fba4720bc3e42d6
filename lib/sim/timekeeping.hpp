// How well the simulator keeps time: how late its periodic steps run
// (physics, the drives, the board, ROBOT_STATE/IR), and how many camera
// frames the render thread dropped. The loop fires a periodic timer at due,
// due + period, ... (catching up after a stall, runtime/timer_queue.hpp), so
// a step's lateness is the time it ran minus its due time.
//
// report() gives the lines to log every report interval (only what fell
// behind in that window); summary() the run's totals.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "runtime/clock.hpp"
#include "sim/cameras.hpp"

namespace harvest::sim {

class Timekeeping {
 public:
  // A step later than `late_after` counts as late.
  explicit Timekeeping(rt::Micros late_after) : late_after_(late_after) {}

  // The run starts (the first report window).
  void start(rt::Micros now) { start_ = window_start_ = now; }
  // Adds a periodic step ("physics", "drives", ...) first due at `first_due`;
  // returns its index.
  std::size_t add_step(std::string name, rt::Micros first_due, rt::Micros period);
  // The next step of `step` ran at `now` (each firing is the next due time:
  // the runner catches up on missed ones).
  void step_ran(std::size_t step, rt::Micros now);
  // A camera frame published, or a tick dropped because the render thread was behind.
  void frame(CameraId camera, bool dropped);

  // Lines for what fell behind since the last call (empty when nothing did),
  // e.g. "camera fixed: rendering fell behind, 12 frames dropped in the last 10 s".
  std::vector<std::string> report(rt::Micros now);
  // The whole run: every step kind and every camera that had frames.
  std::string summary(rt::Micros run_time) const;

  struct StepTotals {
    std::string name;
    int64_t steps = 0, late = 0;
    rt::Micros max_late = 0;
    rt::Micros max_late_at = 0;  // when that step was due, since start()
  };
  const std::vector<StepTotals>& steps() const { return total_; }
  struct FrameTotals {
    int64_t rendered = 0, dropped = 0;
  };
  const FrameTotals& frames(CameraId camera) const { return frames_total_[static_cast<std::size_t>(camera)]; }

 private:
  rt::Micros late_after_;
  struct Schedule {
    rt::Micros next_due, period;
  };
  std::vector<Schedule> schedule_;
  std::vector<StepTotals> total_, window_;
  std::array<FrameTotals, kCameraCount> frames_total_{}, frames_window_{};
  rt::Micros start_ = 0, window_start_ = 0;
};

}  // namespace harvest::sim
