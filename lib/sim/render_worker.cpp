#include "sim/render_worker.hpp"

#include <sched.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace harvest::sim {
namespace {

constexpr int kRenderNice = 10;  // the render thread's nice value above the process's

void signal(int fd) {
  const uint64_t one = 1;
  [[maybe_unused]] const auto w = write(fd, &one, sizeof one);
}

void drain(int fd) {
  uint64_t n = 0;
  [[maybe_unused]] const auto r = read(fd, &n, sizeof n);  // EAGAIN when not signalled: fine
}

}  // namespace

RenderWorker::RenderWorker(RenderFn render, bool threaded) : render_(std::move(render)) {
  if (!threaded) return;
  wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  work_fd_ = eventfd(0, EFD_CLOEXEC);  // the render thread blocks on it
  if (wake_fd_ < 0 || work_fd_ < 0)
    throw std::runtime_error(std::string("render thread: eventfd failed: ") + std::strerror(errno));
  thread_ = std::thread([this] { run(); });
}

RenderWorker::~RenderWorker() {
  if (thread_.joinable()) {
    stopping_.store(true);
    signal(work_fd_);
    thread_.join();
  }
  if (wake_fd_ >= 0) close(wake_fd_);
  if (work_fd_ >= 0) close(work_fd_);
}

bool RenderWorker::submit(FrameRequest request) {
  Slot& s = slots_[static_cast<std::size_t>(request.camera)];
  if (!threaded()) {
    Frame f{request.camera, {}, {}};
    try {
      f.image = render_(request);
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    ++s.rendered;
    inline_done_.push_back(std::move(f));
    return true;
  }
  if (s.state.load(std::memory_order_acquire) != kIdle) {
    ++s.dropped;
    return false;
  }
  s.request = std::move(request);
  s.state.store(kQueued, std::memory_order_release);
  signal(work_fd_);
  return true;
}

std::vector<RenderWorker::Frame> RenderWorker::take() {
  std::vector<Frame> out;
  if (!threaded()) {
    out.swap(inline_done_);
    return out;
  }
  drain(wake_fd_);  // before looking: a frame finished after this signals again
  std::vector<Slot*> done;
  for (Slot& s : slots_)
    if (s.state.load(std::memory_order_acquire) == kDone) done.push_back(&s);
  std::sort(done.begin(), done.end(), [](const Slot* a, const Slot* b) { return a->request.utime < b->request.utime; });
  for (Slot* s : done) {
    out.push_back(std::move(s->frame));
    s->frame = {};
    s->state.store(kIdle, std::memory_order_release);
  }
  return out;
}

RenderWorker::CameraStats RenderWorker::stats(CameraId camera) const {
  const Slot& s = slots_[static_cast<std::size_t>(camera)];
  return {s.rendered.load(), s.dropped.load()};
}

RenderWorker::Slot* RenderWorker::next_queued() {
  Slot* next = nullptr;
  for (Slot& s : slots_)
    if (s.state.load(std::memory_order_acquire) == kQueued && (!next || s.request.utime < next->request.utime))
      next = &s;
  return next;
}

void RenderWorker::run() {
  // On a busy machine the CPU goes to the loop (drives, physics) first: a
  // late frame is dropped, a late drive faults the arm. Raising one's own
  // nice value needs no privilege; if it fails, frames just compete evenly.
  // Never real-time, even when the loop that started it is (or the process
  // was started under chrt): a frame may always wait.
  const sched_param normal{};
  sched_setscheduler(0, SCHED_OTHER, &normal);
  const auto tid = static_cast<id_t>(gettid());
  errno = 0;
  const int nice_now = getpriority(PRIO_PROCESS, tid);
  if (errno == 0) setpriority(PRIO_PROCESS, tid, std::min(nice_now + kRenderNice, 19));
  while (!stopping_.load()) {
    Slot* s = next_queued();
    if (!s) {
      drain(work_fd_);  // blocks until the loop queues a frame (or the destructor signals)
      continue;
    }
    s->state.store(kRendering, std::memory_order_relaxed);
    Frame f{s->request.camera, {}, {}};
    try {
      f.image = render_(s->request);
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    s->frame = std::move(f);
    ++s->rendered;
    s->state.store(kDone, std::memory_order_release);
    signal(wake_fd_);
  }
}

}  // namespace harvest::sim
