// Where camera frames come from: a V4L2 device (through cv::VideoCapture), a
// video file, or a folder of images in name order.
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "config/key.hpp"

namespace harvest::camera {

enum class ReadStatus {
  kFrame,     // a frame was read
  kBadFrame,  // this frame is unusable (e.g. an unreadable file); the next may be fine
  kEnd,       // no more frames (file or folder finished, no loop)
  kLost,      // the device failed; close and reopen
};

struct ReadResult {
  ReadStatus status;
  cv::Mat frame;      // BGR8 when status == kFrame
  std::string error;  // names the device or file
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Throws std::runtime_error naming the device/file when it cannot be opened.
  virtual void open() = 0;
  virtual void close() = 0;
  virtual ReadResult read() = 0;
  virtual std::string describe() const = 0;
};

// The camera driver's `device` keys.
namespace device_keys {
inline constexpr config::Key<std::string> path{"path", "/dev/video0", {}, "",
                                               "the video device, or a number for the OpenCV index"};
inline constexpr config::Key<int> width{"width", 640, {1, 8192}, "px", "requested frame width"};
inline constexpr config::Key<int> height{"height", 480, {1, 8192}, "px", "requested frame height"};
inline constexpr config::Key<std::string> pixel_format{"pixel_format", "", {}, "",
                                                       "FOURCC such as MJPG or YUYV; empty: the driver's default"};
}  // namespace device_keys

struct DeviceOptions {
  std::string device{device_keys::path.fallback};  // path, or a number for the OpenCV index
  int width = device_keys::width.fallback, height = device_keys::height.fallback;
  double fps = 30;
  std::string pixel_format;  // FOURCC such as "MJPG" or "YUYV"; empty = driver default
};

std::unique_ptr<FrameSource> make_device_source(const DeviceOptions& options);
std::unique_ptr<FrameSource> make_video_source(const std::filesystem::path& file, bool loop);
std::unique_ptr<FrameSource> make_folder_source(const std::filesystem::path& folder, bool loop);

// Image files of a folder (by extension, case-insensitive), sorted by name.
std::vector<std::filesystem::path> list_images(const std::filesystem::path& folder);

}  // namespace harvest::camera
