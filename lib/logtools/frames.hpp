// harvest-log frames: camera frames from a log as PNG files, with the fruit
// detections of the same image (paired by header.utime) drawn on them.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::logtools {

struct FramesOptions {
  std::string image_channel;       // CAMERA_FIXED
  std::string detections_channel;  // FRUIT_FIXED; empty: no overlay
  std::string out_dir;
  int every = 1;  // every n-th frame
  int max = 10;   // at most this many files
  // The frame alone, no label or overlay, at the size of the sensor region it
  // shows (a 320x240 frame of a 640x480 sensor comes out 640x480): a folder a
  // camera driver replays as the same sensor (tools/latency_bench.py).
  bool sensor_size = false;
  std::string format = "png";  // png, or bmp: uncompressed, read in a fraction of a PNG's decoding time
};

// Returns the paths written; errors about single frames go to `err`.
// Throws std::runtime_error if the channel has no images or out_dir cannot be made.
std::vector<std::string> write_frames(const std::vector<rt::LogRecord>& log, const FramesOptions& options,
                                      std::ostream& err);

}  // namespace harvest::logtools
