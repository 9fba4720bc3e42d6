#include "logtools/frames.hpp"

#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <stdexcept>

#include "camera/image_codec.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/log_io.hpp"

namespace harvest::logtools {

std::vector<std::string> write_frames(const std::vector<rt::LogRecord>& log, const FramesOptions& o,
                                      std::ostream& err) {
  std::map<int64_t, fruit_detections_t> detections;
  if (!o.detections_channel.empty())
    for (const auto& r : log)
      if (r.channel == o.detections_channel)
        if (auto d = rt::decode<fruit_detections_t>(r.data)) detections[d->header.utime] = *d;

  if (o.format != "png" && o.format != "bmp") throw std::invalid_argument("frames: format png or bmp, not " + o.format);
  std::filesystem::create_directories(o.out_dir);
  std::vector<std::string> written;
  auto write_png = [&](const std::string& channel, int index, const cv::Mat& image) {
    char name[64];
    std::snprintf(name, sizeof name, "%s_%05d.%s", channel.c_str(), index, o.format.c_str());
    const std::string path = (std::filesystem::path(o.out_dir) / name).string();
    if (!cv::imwrite(path, image)) {
      err << "cannot write " << path << "\n";
      return;
    }
    written.push_back(path);
  };
  int index = -1;
  bool any = false;
  for (const auto& r : log) {
    if (r.channel != o.image_channel) continue;
    auto img = rt::decode<image_t>(r.data);
    if (!img) {
      err << o.image_channel << ": a message is not an image_t\n";
      continue;
    }
    any = true;
    ++index;
    if (o.every > 1 && index % o.every != 0) continue;
    if (static_cast<int>(written.size()) >= o.max) break;
    auto decoded = camera::decode_image(*img);
    if (!decoded.ok()) {
      err << o.image_channel << " #" << index << ": " << decoded.error << "\n";
      continue;
    }
    cv::Mat3b canvas = decoded.bgr.clone();
    const cv::Rect2d roi = camera::image_roi(*img);
    if (o.sensor_size) {
      if (roi.width > 0 && roi.height > 0 && cv::Size(canvas.size()) != cv::Size(roi.size()))
        cv::resize(decoded.bgr, canvas, cv::Size(static_cast<int>(roi.width), static_cast<int>(roi.height)), 0, 0,
                   cv::INTER_LINEAR);
      write_png(o.image_channel, index, canvas);
      continue;
    }
    const double sx = roi.width > 0 ? canvas.cols / roi.width : 1.0;
    const double sy = roi.height > 0 ? canvas.rows / roi.height : 1.0;
    auto it = detections.find(img->header.utime);
    std::string label = o.image_channel;
    label.append(" #").append(std::to_string(index));
    if (it != detections.end()) {
      const auto& d = it->second;
      for (int k = 0; k < d.num_fruits; ++k) {
        const auto& f = d.fruits[static_cast<std::size_t>(k)];
        const cv::Point2d c((f.u_px - roi.x) * sx, (f.v_px - roi.y) * sy);
        const int radius = std::max(2, static_cast<int>(0.5 * f.diameter_px * sx));
        const cv::Scalar colour = f.selected ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 255, 0);
        cv::circle(canvas, c, radius, colour, 2, cv::LINE_AA);
        cv::drawMarker(canvas, c, colour, cv::MARKER_CROSS, 8, 1);
        char text[64];
        std::snprintf(text, sizeof text, "%d %.2fm", f.id, static_cast<double>(f.depth_m));
        cv::putText(canvas, text, c + cv::Point2d(radius + 2, 0), cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1,
                    cv::LINE_AA);
      }
      label.append(", ").append(std::to_string(d.num_fruits)).append(" fruit");
    } else if (!o.detections_channel.empty()) {
      label.append(", no detections");
    }
    cv::putText(canvas, label, {5, 15}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    write_png(o.image_channel, index, canvas);
  }
  if (!any) throw std::runtime_error("no image_t messages on channel '" + o.image_channel + "'");
  return written;
}

}  // namespace harvest::logtools
