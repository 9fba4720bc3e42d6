#include "logtools/explain.hpp"

#include <unordered_set>

#include "logtools/reflect.hpp"

namespace harvest::logtools {
namespace {

// Types a node publishes exactly one of per camera frame (the detectors, the
// feature tracker): a frame with no such message live was dropped live.
bool one_per_frame(const std::string& type) {
  return type == "harvest.fruit_detections_t" || type == "harvest.feature_tracks_t";
}

std::string log_time(int64_t t) { return std::to_string(t); }

}  // namespace

void explain_unmatched(CompareReport& report, const std::vector<rt::LogRecord>& recording,
                       const std::set<std::string>& regenerated, int64_t replay_start) {
  // The sensing times (header.utime) of the recorded inputs, before the
  // replay's start and after: a derived message copies its input's.
  std::unordered_set<int64_t> before, from;
  for (const auto& r : recording) {
    if (regenerated.count(r.channel)) continue;
    const Decoded d = decode_any(r.data.data(), r.data.size());
    if (const Field* f = d.fields.find("header.utime")) (r.timestamp < replay_start ? before : from).insert(f->i);
  }
  for (auto& c : report.channels) {
    c.only_recorded_why.assign(c.only_recorded.size(), "");
    for (std::size_t k = 0; k < c.only_recorded.size(); ++k) {
      const int64_t u = c.only_recorded_utime[k];
      if (from.count(u)) continue;  // the input was replayed: nothing in the logs says why
      c.only_recorded_why[k] =
          before.count(u) ? "its input came before the replay's start (log time " + log_time(replay_start) +
                                "), when not every node was running yet"
                          : "its input is not in the recording (lost by the logger, or images recorded at a reduced "
                            "rate)";
    }
    c.only_replayed_why.assign(c.only_replayed.size(), "");
    if (c.recorded == 0) continue;  // nothing live to compare times with
    for (std::size_t k = 0; k < c.only_replayed.size(); ++k) {
      const int64_t t = c.only_replayed_time[k];
      if (t > c.last_recorded_time)
        c.only_replayed_why[k] = "after the live node's last " + c.channel + " (log time " +
                                 log_time(c.last_recorded_time) + "): it had stopped, or the recording ended first";
      else if (t < c.first_recorded_time)
        c.only_replayed_why[k] =
            "before the live node's first " + c.channel + " (log time " + log_time(c.first_recorded_time) + ")";
      else if (one_per_frame(c.type))
        c.only_replayed_why[k] =
            "the live node answered every frame but this one: it dropped the frame (busy, or its receive queue "
            "was full)";
    }
  }
}

}  // namespace harvest::logtools
