#include "runtime/journal_runner.hpp"

#include <optional>
#include <stdexcept>

namespace harvest::rt {

namespace {
constexpr Micros kLookAhead = 5 * kSecond;  // the logger's copy of an input comes within this of the node's
}

JournalRunner::JournalRunner(std::string prefix, Micros start, const Journal& journal)
    : LogicalTimeRunner(std::move(prefix), start, "journal replay"), start_(start), journal_(journal) {}

JournalRunner::~JournalRunner() = default;

void JournalRunner::watch_fd(int, std::function<void()>) {
  throw std::logic_error("replay cannot watch file descriptors: device nodes are not replayed");
}

void JournalRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  ++result_.published;
  const auto* p = static_cast<const uint8_t*>(data);
  published_.push_back({clock_.now(), full_channel(channel), std::vector<uint8_t>(p, p + size)});
}

const JournalEntry* JournalRunner::next_entry() {
  const auto& entries = journal_.entries;
  // Entries before the start are an earlier run of the instance in the same log.
  while (next_ < entries.size() && entries[next_].utime < start_) ++next_;
  return stop_ || next_ == entries.size() ? nullptr : &entries[next_];
}

JournalRunner::Inputs& JournalRunner::inputs_of(const std::string& channel) {
  for (auto& in : inputs_)
    if (in.channel == channel) return in;
  inputs_.push_back({channel, {}});
  return inputs_.back();
}

void replay_journals(const std::string& input_log, const std::vector<JournalRunner*>& runners) {
  LogReader in(input_log);
  for (JournalRunner* r : runners) {
    r->clock_.set(r->start_);
    r->attach_all();
    r->drain();
  }

  // Where each recorded channel goes: the inputs of every runner subscribed to it.
  struct Route {
    std::string channel;  // as in the log
    std::vector<JournalRunner::Inputs*> to;
  };
  std::vector<Route> routes;
  auto route_of = [&](std::string_view channel) -> Route& {
    for (JournalRunner* r : runners)
      if (r->subscriptions_changed_) {  // a node subscribed after attaching: the routes are recomputed
        routes.clear();
        for (JournalRunner* q : runners) q->subscriptions_changed_ = false;
        break;
      }
    for (auto& rt : routes)
      if (rt.channel == channel) return rt;
    Route rt{std::string(channel), {}};
    for (JournalRunner* r : runners) {
      const std::string logical = r->logical_channel(rt.channel);
      if (!logical.empty() && r->is_subscribed(logical)) rt.to.push_back(&r->inputs_of(logical));
    }
    routes.push_back(std::move(rt));
    return routes.back();
  };

  bool done = false;
  Micros read_to = 0;
  // The recorded message on `channel` with `key` for `r`, read ahead in the log as far as `t` + 5 s.
  auto find = [&](JournalRunner::Inputs& inputs, int64_t key, Micros t) -> std::optional<JournalRunner::Held> {
    auto& q = inputs.held;
    for (auto it = q.begin(); it != q.end(); ++it)
      if (it->key == key) {
        const JournalRunner::Held h = *it;
        q.erase(it);
        return h;
      }
    while (!done && read_to <= t + kLookAhead) {
      const LogView* ev = in.next();
      if (ev == nullptr) {
        done = true;
        break;
      }
      read_to = ev->timestamp;
      const Route& route = route_of(ev->channel);
      if (route.to.empty()) continue;
      const JournalRunner::Held h{ev->timestamp, journal_key(ev->data, ev->size), ev->data, ev->size};
      for (JournalRunner::Inputs* to : route.to) {
        // What the live node never handled (before it started, or lost on its way) is let go after a while.
        while (!to->held.empty() && to->held.front().timestamp < ev->timestamp - 2 * kLookAhead) to->held.pop_front();
        to->held.push_back(h);
      }
      if (h.key == key && !q.empty() && q.back().data == h.data) {
        q.pop_back();
        return h;
      }
    }
    return std::nullopt;
  };

  // The journals' entries in the order of their live times (each journal's own order kept).
  for (;;) {
    JournalRunner* r = nullptr;
    const JournalEntry* e = nullptr;
    for (JournalRunner* c : runners) {
      const JournalEntry* ce = c->next_entry();
      if (ce != nullptr && (e == nullptr || ce->utime < e->utime)) {
        r = c;
        e = ce;
      }
    }
    if (r == nullptr) break;
    ++r->next_;
    auto& res = r->result_;
    if (e->timer) {
      const auto id = r->timer_by_label(e->name);
      if (!id) {
        ++res.other_timers;
        continue;
      }
      r->clock_.set(std::max(r->clock_.now(), e->utime));
      const bool one_shot = !r->timers_.periodic(*id);
      r->timers_.fire_now(*id);
      if (one_shot) r->forget_timer(*id);
      ++res.timers;
    } else {
      if (!r->is_subscribed(e->name)) continue;  // the heartbeat's, or a node not replayed
      const auto held = find(r->inputs_of(e->name), e->key, e->utime);
      if (!held) {
        ++res.missing_inputs;
        if (res.missing.size() < 5)
          res.missing.push_back(e->name + " at " + std::to_string(e->utime) + " (not in the recording)");
        continue;
      }
      r->clock_.set(std::max(r->clock_.now(), e->utime));
      r->deliver(e->name, held->data, held->size, r->clock_.now());
      ++res.messages;
    }
    r->drain();
  }
}

}  // namespace harvest::rt
