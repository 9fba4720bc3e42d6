#include "runtime/journal_runner.hpp"

#include <stdexcept>

namespace harvest::rt {

namespace {
constexpr Micros kLookAhead = 5 * kSecond;  // the logger's copy of an input comes within this of the node's
}

JournalRunner::JournalRunner(std::string input_log, std::string output_log, std::string prefix, Micros start)
    : LogicalTimeRunner(std::move(prefix), start, "journal replay"),
      input_log_(std::move(input_log)),
      output_log_(std::move(output_log)),
      start_(start) {}

JournalRunner::~JournalRunner() = default;

void JournalRunner::watch_fd(int, std::function<void()>) {
  throw std::logic_error("replay cannot watch file descriptors: device nodes are not replayed");
}

void JournalRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  ++result_.published;
  if (!out_) return;
  lcm::LogEvent ev{};
  ev.timestamp = clock_.now();
  ev.channel = full_channel(channel);
  ev.datalen = static_cast<int32_t>(size);
  ev.data = const_cast<void*>(data);
  if (out_->writeEvent(&ev) != 0) throw std::runtime_error("cannot write " + output_log_);
}

std::optional<std::vector<uint8_t>> JournalRunner::find(const std::string& channel, int64_t key, Micros t) {
  auto search = [&]() -> std::optional<std::vector<uint8_t>> {
    auto& q = held_[channel];
    for (auto it = q.begin(); it != q.end(); ++it)
      if (it->key == key) {
        std::vector<uint8_t> data = std::move(it->data);
        q.erase(it);
        return data;
      }
    return std::nullopt;
  };
  if (auto found = search()) return found;
  while (!in_done_ && read_to_ <= t + kLookAhead) {
    const lcm::LogEvent* ev = in_->readNextEvent();
    if (ev == nullptr) {
      in_done_ = true;
      break;
    }
    read_to_ = ev->timestamp;
    const std::string logical = logical_channel(ev->channel);
    if (!is_subscribed(logical)) continue;
    auto& q = held_[logical];
    // What the live node never handled (before it started, or lost on its way) is let go after a while.
    while (!q.empty() && q.front().timestamp < ev->timestamp - 2 * kLookAhead) q.pop_front();
    const auto* p = static_cast<const uint8_t*>(ev->data);
    q.push_back({ev->timestamp, journal_key(ev->data, static_cast<std::size_t>(ev->datalen)),
                 std::vector<uint8_t>(p, p + ev->datalen)});
    if (logical == channel && q.back().key == key) {
      std::vector<uint8_t> data = std::move(q.back().data);
      q.pop_back();
      return data;
    }
  }
  return std::nullopt;
}

JournalReplayResult JournalRunner::run(const std::vector<Node*>& nodes, const Journal& journal) {
  in_ = std::make_unique<lcm::LogFile>(input_log_, "r");
  if (!in_->good()) throw std::runtime_error("cannot open log " + input_log_);
  if (!output_log_.empty()) {
    out_ = std::make_unique<lcm::LogFile>(output_log_, "w");
    if (!out_->good()) throw std::runtime_error("cannot create log " + output_log_);
  }
  for (Node* n : nodes) add(*n);
  clock_.set(start_);
  attach_all();
  drain();
  for (const JournalEntry& e : journal.entries) {
    if (stop_) break;
    if (e.utime < start_) continue;  // an earlier run of the instance in the same log
    if (e.timer) {
      const auto id = timer_by_label(e.name);
      if (!id) {
        ++result_.other_timers;
        continue;
      }
      clock_.set(std::max(clock_.now(), e.utime));
      const bool one_shot = !timers_.periodic(*id);
      timers_.fire_now(*id);
      if (one_shot) forget_timer(*id);
      ++result_.timers;
    } else {
      if (!is_subscribed(e.name)) continue;  // the heartbeat's, or a node not replayed
      const auto data = find(e.name, e.key, e.utime);
      if (!data) {
        ++result_.missing_inputs;
        if (result_.missing.size() < 5)
          result_.missing.push_back(e.name + " at " + std::to_string(e.utime) + " (not in the recording)");
        continue;
      }
      clock_.set(std::max(clock_.now(), e.utime));
      deliver(e.name, data->data(), data->size(), clock_.now());
      ++result_.messages;
    }
    drain();
  }
  out_.reset();
  return result_;
}

}  // namespace harvest::rt
