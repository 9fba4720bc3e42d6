#include "runtime/live_runner.hpp"

#include <fcntl.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <stdexcept>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::rt {

LiveRunner::LiveRunner(LiveOptions options) : Dispatcher(options.prefix), options_(std::move(options)) {
  lcm_ = std::make_unique<lcm::LCM>(options_.lcm_url);
  if (!lcm_->good())
    throw std::runtime_error("cannot open LCM" + (options_.lcm_url.empty() ? "" : " at " + options_.lcm_url) +
                             " (is there a multicast route? run tools/harvest netfix)");
  if (pipe2(wake_pipe_, O_CLOEXEC | O_NONBLOCK) != 0) throw std::runtime_error("pipe2 failed");
  if (!options_.journal_instance.empty()) journal_ = std::make_unique<JournalWriter>(options_.journal_instance);
}

LiveRunner::~LiveRunner() {
  close(wake_pipe_[0]);
  close(wake_pipe_[1]);
}

void LiveRunner::request_stop(int exit_code) {
  exit_code_.store(exit_code);
  stop_requested_.store(true);
  const char c = 's';
  [[maybe_unused]] auto r = write(wake_pipe_[1], &c, 1);
}

void LiveRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  if (lcm_->publish(full_channel(channel), data, static_cast<unsigned>(size)) != 0)
    spdlog::warn("LCM publish on {} failed ({} bytes)", full_channel(channel), size);
}

void LiveRunner::watch_fd(int fd, std::function<void()> on_readable) { watched_[fd] = std::move(on_readable); }
void LiveRunner::unwatch_fd(int fd) { watched_.erase(fd); }

void LiveRunner::on_first_subscription(const std::string& channel) {
  // LCM channel names are regular expressions; ours are plain identifiers.
  lcm_->subscribeFunction(full_channel(channel), &LiveRunner::on_lcm_message, this);
}

void LiveRunner::on_lcm_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel, LiveRunner* self) {
  const Micros t = self->clock_.now();
  const std::string logical = self->logical_channel(channel);
  if (self->journal_) self->journal_->message(logical, rbuf->data, rbuf->data_size, t);
  self->event_time_ = t;
  self->deliver(logical, rbuf->data, rbuf->data_size, t);
  self->event_time_.reset();
}

void LiveRunner::flush_journal(bool force) {
  if (!journal_ || journal_->empty() || !(force || journal_->due(clock_.now()))) return;
  const std::vector<uint8_t> buf = encode(journal_->take(clock_.now()));
  publish_bytes(kJournalChannel, buf.data(), buf.size());
}

void LiveRunner::poll_once(Micros max_wait) {
  const Micros now_us = clock_.now();
  Micros wait = max_wait;
  if (auto due = timers_.next_due()) wait = std::clamp<Micros>(*due - now_us, 0, max_wait);
  std::vector<pollfd> fds;
  fds.push_back({lcm_->getFileno(), POLLIN, 0});
  fds.push_back({wake_pipe_[0], POLLIN, 0});
  for (const auto& [fd, cb] : watched_) fds.push_back({fd, POLLIN, 0});
  // To the microsecond: poll()'s milliseconds, rounded up so a timer is never polled for before it is due, made
  // every tick 0.5 ms late on average (the servo controller's commands: docs/performance.md).
  const timespec timeout{static_cast<time_t>(wait / kSecond), static_cast<long>((wait % kSecond) * 1000)};
  const int n = ppoll(fds.data(), fds.size(), &timeout, nullptr);
  if (n > 0) {
    if (fds[1].revents & POLLIN) {
      char buf[64];
      while (read(wake_pipe_[0], buf, sizeof buf) > 0) {
      }
    }
    if (fds[0].revents & POLLIN) lcm_->handle();
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) {
        auto it = watched_.find(fds[i].fd);
        if (it != watched_.end()) {
          auto cb = it->second;  // the callback may unwatch itself
          cb();
        }
      }
    }
  }
  timers_.fire_due(clock_.now(), [this](Micros, TimerId id) {
    // The callback's now() is when it ran (the journal's record of it), not its due time.
    event_time_ = clock_.now();
    if (journal_) journal_->timer(timer_label(id), *event_time_);
    if (!timers_.periodic(id)) forget_timer(id);
  });
  event_time_.reset();
  flush_journal(false);
}

int LiveRunner::run() {
  attach_all();
  while (!stop_requested_.load()) poll_once(100 * kMilli);

  for (Node* n : nodes()) n->begin_shutdown();
  const Micros deadline = clock_.now() + options_.shutdown_timeout;
  auto all_done = [&] {
    return std::all_of(nodes().begin(), nodes().end(), [](Node* n) { return n->shutdown_complete(); });
  };
  while (!all_done() && clock_.now() < deadline) poll_once(10 * kMilli);
  if (!all_done()) spdlog::warn("shutdown timed out after {:.1f} s", to_seconds(options_.shutdown_timeout));
  flush_journal(true);
  return exit_code_.load();
}

}  // namespace harvest::rt
