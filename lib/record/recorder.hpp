// harvest-record: the launcher's recorder (docs/recording-and-replay.md). It
// records an LCM network to a log file as lcm-logger does (same file format,
// same names: FILE.00, FILE.01, ... with -i), and adds what a field run needs:
// chosen channels (the cameras) kept at a reduced rate, a new file every N MB,
// and the size, rate and free disk space told while recording, with a
// warning before the disk fills. Pure parts here; the LCM loop is record_cli.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "runtime/rate_gate.hpp"

namespace lcm {
class LogFile;
}

namespace harvest::record {

// Channels matching `pattern` are kept at most `max_hz` times a second.
struct RateLimit {
  std::string pattern;
  std::regex channels;
  double max_hz = 0;
};

// "REGEX=HZ", e.g. "CAMERA_.*=5". Throws std::invalid_argument saying what is wrong.
RateLimit parse_rate_limit(const std::string& text);

struct RecorderOptions {
  std::filesystem::path file;  // FILE; with increment the parts are FILE.00, FILE.01, ...
  std::string channels = ".*";
  bool invert_channels = false;  // record what does NOT match
  bool increment = false;        // as lcm-logger -i: never overwrite, number the parts
  double split_mb = 0;           // 0: one file; needs increment
  std::vector<RateLimit> rate_limits;
};

struct RecorderStats {
  int64_t bytes = 0;         // written, all parts
  int64_t messages = 0;      // written
  int64_t rate_dropped = 0;  // left out by a rate limit
  int parts = 0;
  std::filesystem::path current;  // the part being written
};

class Recorder {
 public:
  // Opens the first part; throws std::runtime_error naming the file.
  explicit Recorder(RecorderOptions options);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // One received message (receive time in microseconds since the epoch);
  // returns whether it was written. Throws std::runtime_error when a write
  // fails (disk full), naming the file.
  bool on_message(const std::string& channel, int64_t recv_utime, const void* data, uint32_t size);
  void flush();
  const RecorderStats& stats() const { return stats_; }

 private:
  bool wanted(const std::string& channel);
  bool within_rate(const std::string& channel, int64_t utime);
  void open_next();

  RecorderOptions options_;
  std::regex channels_;
  std::map<std::string, bool> wanted_;                // channel -> recorded (regex result cached)
  std::map<std::string, const RateLimit*> limit_of_;  // channel -> its limit, nullptr: none
  std::map<std::string, rt::RateGate> gates_;         // rate-limited channel -> its gate
  std::unique_ptr<lcm::LogFile> log_;
  int64_t part_bytes_ = 0;
  int64_t eventnum_ = 0;
  RecorderStats stats_;
};

// The status line and the disk warnings, from the totals seen at each
// report. Pure: numbers in, text out.
struct MeterOptions {
  double warn_free_mb = 1000;     // warn while less than this is free
  double warn_fill_minutes = 10;  // warn while the disk would fill within this at the current rate
  double repeat_s = 60;           // a standing warning is repeated this often
};

struct MeterReport {
  std::string status;                  // "recording: 123.4 MB in 1 file, 4.52 MB/s, 40.1 GB free (2.5 h at this rate)"
  std::optional<std::string> warning;  // "warning: ..." when one is due
};

class RecordingMeter {
 public:
  RecordingMeter(MeterOptions options, std::filesystem::path folder) : options_(options), folder_(std::move(folder)) {}
  // t_s: seconds since recording started; free_bytes: free space on the folder's disk.
  MeterReport update(double t_s, const RecorderStats& stats, double free_bytes);

 private:
  MeterOptions options_;
  std::filesystem::path folder_;
  double last_t_ = 0;
  int64_t last_bytes_ = 0;
  double rate_ = 0;  // bytes per second over the last period
  double last_warned_ = -1e9;
};

// Free bytes for an unprivileged writer on the disk holding `path` (statvfs);
// -1 if it cannot be read.
double free_bytes(const std::filesystem::path& path);

// "123.4 MB", "40.1 GB"
std::string human_bytes(double bytes);

}  // namespace harvest::record
