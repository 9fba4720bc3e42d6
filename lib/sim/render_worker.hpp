// Renders the simulated cameras off the loop that serves the drives and runs
// the physics: a frame costs milliseconds to tens of milliseconds, and on a
// busy machine a loop that renders misses the drives' SYNC/PDO deadlines and
// lets ROBOT_STATE go stale (docs/simulator.md, "Threads and keeping time").
//
// The loop submits a FrameRequest (a snapshot of what the frame shows) at each
// camera tick; the render thread renders it and hands the encoded frame back;
// the loop takes it (wake_fd() is readable then) and publishes it itself, so
// LCM and the node's API stay on one thread. A camera whose previous frame is
// not taken yet drops the new tick and counts it: frames never queue up
// behind a slow renderer, and a published frame is at most one render old.
//
// The loop never waits for the render thread: each camera has one slot whose
// state (idle, queued, rendering, done) says who may touch it, handed over
// with atomics; the two threads wake each other through eventfds. No lock, so
// a render thread preempted at a low priority cannot hold up the loop.
//
// Inline (replays, on logical time) submit() renders at once on the caller's
// thread, as the simulator always did, so replays stay deterministic.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
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
    int64_t dropped = 0;   // ticks dropped because the camera's previous frame was not taken yet
  };

  // `render` runs on the render thread (threaded) or in submit() (inline).
  RenderWorker(RenderFn render, bool threaded);
  ~RenderWorker();  // finishes the frame in progress, drops the rest, joins
  RenderWorker(const RenderWorker&) = delete;
  RenderWorker& operator=(const RenderWorker&) = delete;

  bool threaded() const { return thread_.joinable(); }
  // The loop: queues the frame; false (dropped, counted) while the camera's
  // previous frame is queued, being rendered or not taken yet. Never waits.
  bool submit(FrameRequest request);
  // The loop: the frames rendered since the last call, oldest tick first.
  std::vector<Frame> take();
  // Threaded: readable while frames wait to be taken (an eventfd; take()
  // resets it). Inline: -1.
  int wake_fd() const { return wake_fd_; }
  CameraStats stats(CameraId camera) const;

 private:
  enum State : int { kIdle, kQueued, kRendering, kDone };
  struct Slot {
    std::atomic<int> state{kIdle};
    FrameRequest request;  // written by the loop while idle, read by the render thread once queued
    Frame frame;           // written by the render thread while rendering, read by the loop once done
    std::atomic<int64_t> rendered{0}, dropped{0};
  };
  void run();
  // The queued slot with the oldest tick, or null.
  Slot* next_queued();

  RenderFn render_;
  std::array<Slot, kCameraCount> slots_;
  std::vector<Frame> inline_done_;
  std::atomic<bool> stopping_{false};
  int wake_fd_ = -1;  // render thread -> loop
  int work_fd_ = -1;  // loop -> render thread
  std::thread thread_;
};

}  // namespace harvest::sim
