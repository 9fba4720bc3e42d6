// Time as nodes see it. A node never reads the wall clock: the runner injects
// a Clock (system time when live, log time in replay), so replays are exact.
#pragma once

#include <cstdint>

namespace harvest::rt {

// Microseconds since the Unix epoch, the unit of every utime on the bus.
using Micros = int64_t;

constexpr Micros kSecond = 1'000'000;
constexpr Micros kMilli = 1'000;

inline constexpr double to_seconds(Micros us) { return static_cast<double>(us) * 1e-6; }
inline constexpr Micros from_seconds(double s) { return static_cast<Micros>(s * 1e6 + (s >= 0 ? 0.5 : -0.5)); }

class Clock {
 public:
  virtual ~Clock() = default;
  virtual Micros now() const = 0;
};

// The real time, for live runs and for device drivers stamping captures.
class SystemClock final : public Clock {
 public:
  Micros now() const override;
};

// A clock that only moves when told to: replay, simulation and unit tests.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(Micros start = 0) : now_(start) {}
  Micros now() const override { return now_; }
  void set(Micros t) { now_ = t; }
  void advance(Micros dt) { now_ += dt; }

 private:
  Micros now_;
};

// Wall-clock time; for runners and hardware drivers only, never inside a node.
Micros wall_time_now();

}  // namespace harvest::rt
