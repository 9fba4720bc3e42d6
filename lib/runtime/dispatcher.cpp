#include "runtime/dispatcher.hpp"

#include <spdlog/spdlog.h>

#include <exception>

namespace harvest::rt {

void Dispatcher::subscribe_bytes(const std::string& channel, RawHandler handler) {
  auto& list = handlers_[channel];
  list.push_back(std::move(handler));
  if (list.size() == 1) on_first_subscription(channel);
}

TimerId Dispatcher::add_timer(Micros first_due, Micros period, std::function<void()> callback,
                              const std::string& owner) {
  const TimerId id = timers_.add(first_due, period, std::move(callback));
  const std::string label =
      owner.empty() ? "#" + std::to_string(id) : owner + "#" + std::to_string(timers_per_owner_[owner]++);
  timer_labels_[id] = label;
  timer_ids_[label] = id;
  return id;
}

void Dispatcher::cancel_timer(TimerId id) {
  timers_.cancel(id);
  forget_timer(id);
}

void Dispatcher::forget_timer(TimerId id) {
  auto it = timer_labels_.find(id);
  if (it == timer_labels_.end()) return;
  timer_ids_.erase(it->second);
  timer_labels_.erase(it);
}

std::string Dispatcher::timer_label(TimerId id) const {
  auto it = timer_labels_.find(id);
  return it == timer_labels_.end() ? "#" + std::to_string(id) : it->second;
}

std::optional<TimerId> Dispatcher::timer_by_label(const std::string& label) const {
  auto it = timer_ids_.find(label);
  if (it == timer_ids_.end()) return std::nullopt;
  return it->second;
}

std::string Dispatcher::logical_channel(const std::string& full) const {
  if (full.compare(0, prefix_.size(), prefix_) != 0) return {};
  return full.substr(prefix_.size());
}

void Dispatcher::attach_all() {
  for (Node* n : nodes_) n->attach(*this);
}

void Dispatcher::deliver(const std::string& channel, const void* data, std::size_t size, Micros receive_time) {
  auto it = handlers_.find(channel);
  if (it == handlers_.end()) return;
  MessageInfo info{&it->first, receive_time, size};
  // Index loop: a handler may subscribe (and so grow the list) while we run.
  for (std::size_t i = 0; i < it->second.size(); ++i) {
    RawHandler h = it->second[i];
    // Node::subscribe catches and counts its handlers' exceptions; this only
    // keeps a raw handler's from taking the runner down.
    try {
      h(data, size, info);
    } catch (const std::exception& e) {
      int64_t suppressed = 0;
      Micros since = 0;
      if (raw_handler_log_.admit(receive_time, suppressed, since))
        spdlog::error("handling a message on {} failed: {} ({} more since the last report)", channel, e.what(),
                      suppressed);
    }
  }
}

}  // namespace harvest::rt
