#include "camera/frame_source.hpp"

#include <algorithm>
#include <cctype>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

namespace harvest::camera {

namespace {

cv::Mat to_bgr(const cv::Mat& m) {
  if (m.type() == CV_8UC3) return m;
  cv::Mat out;
  if (m.channels() == 1)
    cv::cvtColor(m, out, cv::COLOR_GRAY2BGR);
  else if (m.channels() == 4)
    cv::cvtColor(m, out, cv::COLOR_BGRA2BGR);
  else
    return {};
  if (out.depth() != CV_8U) out.convertTo(out, CV_8U);
  return out;
}

class CaptureSource : public FrameSource {
 public:
  CaptureSource(std::string what, bool is_device, DeviceOptions options, bool loop)
      : what_(std::move(what)), is_device_(is_device), options_(std::move(options)), loop_(loop) {}

  void open() override {
    close();
    bool ok = false;
    try {
      if (is_device_) {
        const bool numeric = !what_.empty() && std::all_of(what_.begin(), what_.end(), ::isdigit);
        ok = numeric ? cap_.open(std::stoi(what_), cv::CAP_V4L2) : cap_.open(what_, cv::CAP_V4L2);
        if (ok) {
          if (options_.pixel_format.size() == 4) {
            const auto& f = options_.pixel_format;
            cap_.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(f[0], f[1], f[2], f[3]));
          }
          cap_.set(cv::CAP_PROP_FRAME_WIDTH, options_.width);
          cap_.set(cv::CAP_PROP_FRAME_HEIGHT, options_.height);
          cap_.set(cv::CAP_PROP_FPS, options_.fps);
        }
      } else {
        if (!std::filesystem::is_regular_file(what_))
          throw std::runtime_error("video file " + what_ + ": no such file");
        ok = cap_.open(what_);
      }
    } catch (const cv::Exception& e) {
      throw std::runtime_error("cannot open " + describe() + ": " + e.what());
    }
    if (!ok || !cap_.isOpened())
      throw std::runtime_error("cannot open " + describe() +
                               (is_device_ ? " (missing, busy or no permission)" : " (not a readable video)"));
  }

  void close() override { cap_.release(); }

  ReadResult read() override {
    cv::Mat frame;
    bool ok = false;
    try {
      ok = cap_.read(frame);
    } catch (const cv::Exception& e) {
      return {ReadStatus::kLost, {}, describe() + ": " + e.what()};
    }
    if (!ok || frame.empty()) {
      if (is_device_) return {ReadStatus::kLost, {}, describe() + ": no frame (unplugged?)"};
      if (!loop_) return {ReadStatus::kEnd, {}, describe() + ": end of video"};
      cap_.set(cv::CAP_PROP_POS_FRAMES, 0);
      if (!cap_.read(frame) || frame.empty()) return {ReadStatus::kEnd, {}, describe() + ": no frames"};
    }
    cv::Mat bgr = to_bgr(frame);
    if (bgr.empty()) return {ReadStatus::kBadFrame, {}, describe() + ": unsupported pixel type"};
    return {ReadStatus::kFrame, bgr, {}};
  }

  std::string describe() const override { return (is_device_ ? "camera device " : "video file ") + what_; }

 private:
  std::string what_;
  bool is_device_;
  DeviceOptions options_;
  bool loop_;
  cv::VideoCapture cap_;
};

class FolderSource : public FrameSource {
 public:
  FolderSource(std::filesystem::path folder, bool loop) : folder_(std::move(folder)), loop_(loop) {}

  void open() override {
    if (!std::filesystem::is_directory(folder_))
      throw std::runtime_error("image folder " + folder_.string() + ": no such folder");
    files_ = list_images(folder_);
    if (files_.empty()) throw std::runtime_error("image folder " + folder_.string() + ": no image files");
    next_ = 0;
  }
  void close() override {}

  ReadResult read() override {
    if (next_ >= files_.size()) {
      if (!loop_) return {ReadStatus::kEnd, {}, describe() + ": end of folder"};
      next_ = 0;
    }
    const std::filesystem::path& file = files_[next_++];
    cv::Mat img;
    try {
      img = cv::imread(file.string(), cv::IMREAD_COLOR);
    } catch (const cv::Exception&) {
      img.release();
    }
    if (img.empty()) return {ReadStatus::kBadFrame, {}, "cannot read image " + file.string()};
    return {ReadStatus::kFrame, img, {}};
  }

  std::string describe() const override { return "image folder " + folder_.string(); }

 private:
  std::filesystem::path folder_;
  bool loop_;
  std::vector<std::filesystem::path> files_;
  std::size_t next_ = 0;
};

}  // namespace

std::vector<std::filesystem::path> list_images(const std::filesystem::path& folder) {
  static const std::vector<std::string> kExt = {".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".tif", ".tiff"};
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(folder)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (std::find(kExt.begin(), kExt.end(), ext) != kExt.end()) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::unique_ptr<FrameSource> make_device_source(const DeviceOptions& options) {
  return std::make_unique<CaptureSource>(options.device, true, options, false);
}
std::unique_ptr<FrameSource> make_video_source(const std::filesystem::path& file, bool loop) {
  return std::make_unique<CaptureSource>(file.string(), false, DeviceOptions{}, loop);
}
std::unique_ptr<FrameSource> make_folder_source(const std::filesystem::path& folder, bool loop) {
  return std::make_unique<FolderSource>(folder, loop);
}

}  // namespace harvest::camera
