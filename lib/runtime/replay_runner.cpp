#include "runtime/replay_runner.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "runtime/log_io.hpp"

namespace harvest::rt {

ReplayRunner::ReplayRunner(ReplayOptions options)
    : LogicalTimeRunner(options.prefix, 0, "replay"), options_(std::move(options)) {}

ReplayRunner::~ReplayRunner() = default;

void ReplayRunner::watch_fd(int, std::function<void()>) {
  throw std::logic_error("replay cannot watch file descriptors: device nodes are not replayed");
}

void ReplayRunner::request_stop(int exit_code) {
  stop_ = true;
  result_.exit_code = exit_code;
}

void ReplayRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  ++result_.messages_published;
  if (out_) {
    // Thrown here it would be caught at the handler boundary and counted like
    // a node's error; a replay that cannot write its output must stop instead.
    if (!write_event(*out_, clock_.now(), full_channel(channel), data, size)) {
      write_failed_ = true;
      stop_ = true;
    }
  }
  if (options_.isolated) return;  // the other nodes get the recorded message instead
  queue(channel, data, size);
}

void ReplayRunner::fire_timers_until(Micros t) {
  result_.timers_fired += fire_until(t, [this] { return stop_; });
}

void ReplayRunner::add_from(Node& node, Micros start) {
  const auto at = std::upper_bound(late_.begin(), late_.end(), start,
                                   [](Micros t, const std::pair<Micros, Node*>& e) { return t < e.first; });
  late_.insert(at, {start, &node});
}

void ReplayRunner::attach_due(Micros t) {
  for (; late_attached_ < late_.size() && late_[late_attached_].first <= t && !stop_; ++late_attached_) {
    const auto [start, node] = late_[late_attached_];
    fire_timers_until(start);  // the others' timers due before it started
    clock_.set(std::max(clock_.now(), start));
    node->attach(*this);
    drain();
  }
}

ReplayResult ReplayRunner::run() {
  LogReader in(options_.input_log);
  if (!options_.output_log.empty()) {
    out_ = std::make_unique<lcm::LogFile>(options_.output_log, "w");
    if (!out_->good()) throw std::runtime_error("cannot create log " + options_.output_log);
  }

  const LogView* ev = in.next();
  if (ev == nullptr) {
    attach_all();
    return result_;
  }
  clock_.set(ev->timestamp);
  result_.first_time = ev->timestamp;
  attach_all();
  drain();
  attach_due(ev->timestamp);  // those that started before the log's first event: at it

  std::string channel, logical;  // reused: no allocation per event
  for (; ev != nullptr && !stop_; ev = in.next()) {
    if (options_.end_time && ev->timestamp > *options_.end_time) break;
    ++result_.events_read;
    attach_due(ev->timestamp);
    fire_timers_until(ev->timestamp);
    if (stop_) break;
    clock_.set(std::max(clock_.now(), ev->timestamp));
    result_.last_time = clock_.now();
    channel.assign(ev->channel);
    if (options_.copy_inputs && out_) write_event(*out_, ev->timestamp, channel, ev->data, ev->size);
    if (channel.compare(0, prefix().size(), prefix()) != 0) continue;  // not the recorded graph's
    logical.assign(channel, prefix().size());
    if (advertised().count(logical) && !options_.isolated) {  // regenerated: not fed in
      ++result_.events_skipped;
      continue;
    }
    if (!is_subscribed(logical)) continue;
    ++result_.events_delivered;
    deliver(logical, ev->data, ev->size, clock_.now());
    drain();
  }
  if (!stop_ && options_.tail > 0) fire_timers_until(result_.last_time + options_.tail);
  out_.reset();
  if (write_failed_) throw std::runtime_error("cannot write " + options_.output_log);
  return result_;
}

}  // namespace harvest::rt
