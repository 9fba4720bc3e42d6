#include "record/recorder.hpp"

#include <sys/statvfs.h>

#include <cmath>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>

namespace harvest::record {

namespace {
constexpr double kMB = 1024.0 * 1024.0;  // lcm-logger's MB (--split-mb)
// An event on disk: sync word, event number, timestamp, channel and data
// lengths (lcm eventlog format), then the channel name and the payload.
constexpr int64_t kEventOverhead = 4 + 8 + 8 + 4 + 4;

std::string duration(double s) {
  char buf[32];
  if (s >= 5400)
    std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  else if (s >= 90)
    std::snprintf(buf, sizeof buf, "%.0f min", s / 60);
  else
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  return buf;
}
}  // namespace

RateLimit parse_rate_limit(const std::string& text) {
  const auto eq = text.rfind('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw std::invalid_argument("'" + text + "': expected CHANNEL_REGEX=HZ, e.g. CAMERA_.*=5");
  RateLimit r;
  r.pattern = text.substr(0, eq);
  try {
    r.channels = std::regex(r.pattern);
  } catch (const std::regex_error& e) {
    throw std::invalid_argument("'" + text + "': bad channel regular expression: " + e.what());
  }
  std::size_t used = 0;
  try {
    r.max_hz = std::stod(text.substr(eq + 1), &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() - eq - 1 || !(r.max_hz > 0) || !std::isfinite(r.max_hz))
    throw std::invalid_argument("'" + text + "': the rate must be a number of messages per second > 0");
  return r;
}

Recorder::Recorder(RecorderOptions options) : options_(std::move(options)) {
  try {
    channels_ = std::regex(options_.channels);
  } catch (const std::regex_error& e) {
    throw std::runtime_error("bad channel regular expression '" + options_.channels + "': " + e.what());
  }
  if (options_.split_mb > 0 && !options_.increment)
    throw std::runtime_error("splitting by size (--split-mb) needs -i (numbered parts)");
  open_next();
}

Recorder::~Recorder() = default;

void Recorder::open_next() {
  std::filesystem::path path = options_.file;
  if (options_.increment) {
    for (int i = 0;; ++i) {
      char suffix[16];
      std::snprintf(suffix, sizeof suffix, ".%02d", i);
      path = options_.file.string() + suffix;
      if (!std::filesystem::exists(path)) break;
    }
  } else if (std::filesystem::exists(path)) {
    throw std::runtime_error(path.string() + " exists; not overwriting it (use -i for numbered parts)");
  }
  if (log_) flush();
  auto log = std::make_unique<lcm::LogFile>(path.string(), "w");
  if (!log->good()) throw std::runtime_error("cannot write " + path.string());
  log_ = std::move(log);
  part_bytes_ = 0;
  ++stats_.parts;
  stats_.current = path;
}

bool Recorder::wanted(const std::string& channel) {
  auto it = wanted_.find(channel);
  if (it == wanted_.end())
    it = wanted_.emplace(channel, std::regex_match(channel, channels_) != options_.invert_channels).first;
  return it->second;
}

bool Recorder::within_rate(const std::string& channel, int64_t utime) {
  auto lim = limit_of_.find(channel);
  if (lim == limit_of_.end()) {
    const RateLimit* found = nullptr;
    for (const auto& r : options_.rate_limits)
      if (std::regex_match(channel, r.channels)) {
        found = &r;
        break;
      }
    lim = limit_of_.emplace(channel, found).first;
  }
  if (lim->second == nullptr) return true;
  return gates_.try_emplace(channel, lim->second->max_hz).first->second.admit(utime);
}

bool Recorder::on_message(const std::string& channel, int64_t recv_utime, const void* data, uint32_t size) {
  if (!wanted(channel)) return false;
  if (!within_rate(channel, recv_utime)) {
    ++stats_.rate_dropped;
    return false;
  }
  const int64_t event_bytes = kEventOverhead + static_cast<int64_t>(channel.size()) + size;
  if (options_.split_mb > 0 && part_bytes_ > 0 && part_bytes_ + event_bytes > options_.split_mb * kMB) open_next();
  lcm::LogEvent ev;
  ev.eventnum = eventnum_++;
  ev.timestamp = recv_utime;
  ev.channel = channel;
  ev.datalen = static_cast<int32_t>(size);
  ev.data = const_cast<void*>(data);
  if (log_->writeEvent(&ev) != 0) throw std::runtime_error("cannot write " + stats_.current.string());
  part_bytes_ += event_bytes;
  stats_.bytes += event_bytes;
  ++stats_.messages;
  return true;
}

void Recorder::flush() {
  if (log_ && std::fflush(log_->getFilePtr()) != 0)
    throw std::runtime_error("cannot write " + stats_.current.string() + " (disk full?)");
}

MeterReport RecordingMeter::update(double t_s, const RecorderStats& stats, double free) {
  if (t_s > last_t_) {
    rate_ = static_cast<double>(stats.bytes - last_bytes_) / (t_s - last_t_);
    last_t_ = t_s;
    last_bytes_ = stats.bytes;
  }
  MeterReport r;
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.2f MB/s", rate_ / kMB);
  r.status = "recording: " + human_bytes(static_cast<double>(stats.bytes)) + " in " + std::to_string(stats.parts) +
             (stats.parts == 1 ? " file" : " files") + " (" + stats.current.filename().string() + "), " + rate;
  if (free >= 0) {
    r.status += ", " + human_bytes(free) + " free";
    if (rate_ > 0) r.status += " (" + duration(free / rate_) + " at this rate)";
  }
  if (stats.rate_dropped > 0)
    r.status += ", " + std::to_string(stats.rate_dropped) + " messages left out by rate limits";

  std::string warning;
  if (free >= 0 && free < options_.warn_free_mb * kMB)
    warning = "only " + human_bytes(free) + " free on the disk holding " + folder_.string() + " (warning below " +
              human_bytes(options_.warn_free_mb * kMB) + "): free space, or the recording stops when it is full";
  else if (free >= 0 && rate_ > 0 && free / rate_ < options_.warn_fill_minutes * 60)
    warning = "the disk holding " + folder_.string() + " fills in about " + duration(free / rate_) + " at " + rate +
              " (" + human_bytes(free) + " free): free space, lower recording.image_rate_hz, or stop the run";
  if (!warning.empty() && t_s - last_warned_ >= options_.repeat_s) {
    r.warning = "warning: " + warning;
    last_warned_ = t_s;
  }
  return r;
}

double free_bytes(const std::filesystem::path& path) {
  struct statvfs s {};
  if (statvfs(path.c_str(), &s) != 0) return -1;
  return static_cast<double>(s.f_bavail) * static_cast<double>(s.f_frsize);
}

std::string human_bytes(double bytes) {
  char buf[32];
  if (bytes >= 1024 * kMB)
    std::snprintf(buf, sizeof buf, "%.1f GB", bytes / (1024 * kMB));
  else
    std::snprintf(buf, sizeof buf, "%.1f MB", bytes / kMB);
  return buf;
}

}  // namespace harvest::record
