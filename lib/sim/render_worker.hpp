// Renders the simulated cameras off the loop that serves the drives and runs
// the physics: a frame costs milliseconds to tens of milliseconds, and on a
// busy machine a loop that renders misses the drives' SYNC/PDO deadlines and
// lets ROBOT_STATE go stale (docs/simulator.md, "Threads").
//
// The loop submits a FrameRequest (a snapshot of what the frame shows) at each
// camera tick; one render thread renders the requests in order and hands the
// encoded frames back; the loop takes them (wake_fd() is readable then) and
// publishes them itself, so LCM and the node's API stay on one thread. A
// camera whose previous frame is not rendered yet drops the new tick and
// counts it: frames never queue up behind a slow renderer, and a published
// frame is at most one render old.
//
// Inline (replays, on logical time) submit() renders at once on the caller's
// thread, as the simulator always did, so replays stay deterministic.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sim/cameras.hpp"

namespace harvest::sim {

class RenderWorker {
 public:
  using RenderFn = std::function<image_t(const FrameRequest&)>;

  struct Frame {
    CameraId camera = CameraId::kFixed;
    image_t image;
    std::string error;  // non-empty: the render threw this, and image is empty
  };
  struct CameraStats {
    int64_t rendered = 0;  // frames handed back (errors included)
    int64_t dropped = 0;   // ticks dropped because the camera's previous frame was not rendered yet
  };

  // `render` runs on the render thread (threaded) or in submit() (inline).
  RenderWorker(RenderFn render, bool threaded);
  ~RenderWorker();  // finishes the frame in progress, drops the rest, joins
  RenderWorker(const RenderWorker&) = delete;
  RenderWorker& operator=(const RenderWorker&) = delete;

  bool threaded() const { return thread_.joinable(); }
  // Queues the frame; false (dropped, counted) while the camera's previous
  // frame is still waiting or being rendered. Never waits for a render.
  bool submit(FrameRequest request);
  // The frames rendered since the last call, in the order they were rendered.
  std::vector<Frame> take();
  // Threaded: readable while frames wait to be taken (an eventfd; take()
  // resets it). Inline: -1.
  int wake_fd() const { return wake_fd_; }
  CameraStats stats(CameraId camera) const;

 private:
  void run();

  RenderFn render_;
  mutable std::mutex mutex_;
  std::condition_variable wake_worker_;
  std::deque<FrameRequest> queue_;         // at most one per camera
  std::array<bool, kCameraCount> busy_{};  // a frame of this camera is queued or being rendered
  std::vector<Frame> done_;
  std::array<CameraStats, kCameraCount> stats_{};
  bool stopping_ = false;
  int wake_fd_ = -1;
  std::thread thread_;
};

}  // namespace harvest::sim
