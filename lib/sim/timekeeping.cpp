#include "sim/timekeeping.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace harvest::sim {
namespace {

double ms(rt::Micros t) { return static_cast<double>(t) / 1000.0; }

}  // namespace

std::size_t Timekeeping::add_step(std::string name, rt::Micros first_due, rt::Micros period) {
  schedule_.push_back({first_due, period});
  total_.push_back({name, 0, 0, 0, 0});
  window_.push_back({std::move(name), 0, 0, 0, 0});
  return total_.size() - 1;
}

void Timekeeping::step_ran(std::size_t step, rt::Micros now) {
  Schedule& s = schedule_.at(step);
  const rt::Micros due = s.next_due;
  const rt::Micros late = std::max<rt::Micros>(now - due, 0);
  s.next_due += s.period;
  for (StepTotals* t : {&total_.at(step), &window_.at(step)}) {
    ++t->steps;
    if (late > late_after_) ++t->late;
    if (late > t->max_late) {
      t->max_late = late;
      t->max_late_at = due - start_;
    }
  }
}

void Timekeeping::frame(CameraId camera, bool dropped) {
  const auto k = static_cast<std::size_t>(camera);
  for (FrameTotals* t : {&frames_total_[k], &frames_window_[k]}) (dropped ? t->dropped : t->rendered) += 1;
}

std::vector<std::string> Timekeeping::report(rt::Micros now) {
  std::vector<std::string> lines;
  const double window_s = rt::to_seconds(now - window_start_);
  for (StepTotals& w : window_) {
    if (w.late > 0)
      lines.push_back(fmt::format(
          "{} steps fell behind: {} of {} late by more than {:.0f} ms in the last {:.0f} s "
          "(at most {:.1f} ms, at t={:.2f} s)",
          w.name, w.late, w.steps, ms(late_after_), window_s, ms(w.max_late), rt::to_seconds(w.max_late_at)));
    w = {w.name, 0, 0, 0, 0};
  }
  for (int c = 0; c < kCameraCount; ++c) {
    FrameTotals& w = frames_window_[static_cast<std::size_t>(c)];
    if (w.dropped > 0)
      lines.push_back(fmt::format("camera {}: rendering fell behind, {} frames dropped in the last {:.0f} s",
                                  camera_name(static_cast<CameraId>(c)), w.dropped, window_s));
    w = {};
  }
  window_start_ = now;
  return lines;
}

std::string Timekeeping::summary(rt::Micros run_time) const {
  std::string s = fmt::format("timekeeping over {:.1f} s:", rt::to_seconds(run_time));
  for (const StepTotals& t : total_)
    s += fmt::format(" {} {} steps, {} late by more than {:.0f} ms, at most {:.1f} ms late (t={:.2f} s);", t.name,
                     t.steps, t.late, ms(late_after_), ms(t.max_late), rt::to_seconds(t.max_late_at));
  for (int c = 0; c < kCameraCount; ++c) {
    const FrameTotals& t = frames_total_[static_cast<std::size_t>(c)];
    if (t.rendered + t.dropped > 0)
      s += fmt::format(" camera {} {} frames rendered, {} dropped;", camera_name(static_cast<CameraId>(c)), t.rendered,
                       t.dropped);
  }
  s.pop_back();
  return s;
}

}  // namespace harvest::sim
