#include "sim/render_worker.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace harvest::sim {

RenderWorker::RenderWorker(RenderFn render, bool threaded) : render_(std::move(render)) {
  if (!threaded) return;
  wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) throw std::runtime_error(std::string("render thread: eventfd failed: ") + std::strerror(errno));
  thread_ = std::thread([this] { run(); });
}

RenderWorker::~RenderWorker() {
  if (thread_.joinable()) {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_worker_.notify_one();
    thread_.join();
  }
  if (wake_fd_ >= 0) close(wake_fd_);
}

bool RenderWorker::submit(FrameRequest request) {
  const auto k = static_cast<std::size_t>(request.camera);
  if (!threaded()) {
    Frame f{request.camera, {}, {}};
    try {
      f.image = render_(request);
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    std::lock_guard lock(mutex_);
    ++stats_[k].rendered;
    done_.push_back(std::move(f));
    return true;
  }
  {
    std::lock_guard lock(mutex_);
    if (busy_[k]) {
      ++stats_[k].dropped;
      return false;
    }
    busy_[k] = true;
    queue_.push_back(std::move(request));
  }
  wake_worker_.notify_one();
  return true;
}

std::vector<RenderWorker::Frame> RenderWorker::take() {
  if (wake_fd_ >= 0) {
    uint64_t n = 0;
    [[maybe_unused]] const auto r = read(wake_fd_, &n, sizeof n);  // EAGAIN when nothing was signalled: fine
  }
  std::lock_guard lock(mutex_);
  std::vector<Frame> out;
  out.swap(done_);
  return out;
}

RenderWorker::CameraStats RenderWorker::stats(CameraId camera) const {
  std::lock_guard lock(mutex_);
  return stats_[static_cast<std::size_t>(camera)];
}

void RenderWorker::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_worker_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    FrameRequest request = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    // The renderer and its scene belong to this thread alone; the request is
    // this thread's copy.
    Frame f{request.camera, {}, {}};
    try {
      f.image = render_(request);
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    lock.lock();
    const auto k = static_cast<std::size_t>(request.camera);
    busy_[k] = false;
    ++stats_[k].rendered;
    done_.push_back(std::move(f));
    const uint64_t one = 1;
    [[maybe_unused]] const auto w = write(wake_fd_, &one, sizeof one);
  }
}

}  // namespace harvest::sim
