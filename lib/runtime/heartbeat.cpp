#include "runtime/heartbeat.hpp"

#include <harvest/config_snapshot_t.hpp>
#include <harvest/process_status_t.hpp>

#include "runtime/channels.hpp"

namespace harvest::rt {

HeartbeatNode::HeartbeatNode(ProcessIdentity id, std::vector<const Node*> watched, Micros period)
    : Node("heartbeat"), id_(std::move(id)), watched_(std::move(watched)), period_(period) {}

void HeartbeatNode::on_attach() {
  advertise(channels::kConfig);
  advertise(channels::kProcessStatus);
  start_ = now();
  harvest::config_snapshot_t cfg{};
  cfg.header.utime = start_;
  cfg.header.frame_id = id_.instance;
  cfg.header.source_seq = -1;
  cfg.process = id_.process;
  cfg.instance = id_.instance;
  cfg.config_path = id_.config_path;
  cfg.yaml = id_.config_yaml;
  cfg.command_line = id_.command_line;
  cfg.version = id_.version;
  publish(channels::kConfig, cfg);
  beat();
  every(period_, [this] { beat(); });
}

void HeartbeatNode::begin_shutdown() {
  stopping_ = true;
  beat();
}

void HeartbeatNode::beat() {
  harvest::process_status_t s{};
  s.header.utime = now();
  s.header.frame_id = id_.instance;
  s.header.source_seq = -1;
  s.process = id_.process;
  s.instance = id_.instance;
  s.host = id_.host;
  s.pid = id_.pid;
  s.uptime_us = now() - start_;
  Health worst = Health::kOk;
  std::string message;
  int64_t handler_errors = 0;
  for (const Node* n : watched_) {
    const NodeStats& st = n->stats();
    s.messages_received += st.received;
    s.messages_published += st.published;
    s.decode_errors += st.decode_errors;
    handler_errors += st.handler_errors;
    for (const auto& [name, value] : st.counters) {
      s.counter_names.push_back(watched_.size() > 1 ? n->name() + "." + name : name);
      s.counter_values.push_back(value);
    }
    // Worst health wins; kStarting ranks below kOk only while nothing is wrong.
    const Health h = n->health();
    auto rank = [](Health x) {
      switch (x) {
        case Health::kOk: return 0;
        case Health::kStarting: return 1;
        case Health::kDegraded: return 2;
        case Health::kError: return 3;
        case Health::kStopping: return 4;
      }
      return 0;
    };
    if (rank(h) > rank(worst)) worst = h;
    if (!n->health_message().empty()) message += (message.empty() ? "" : "; ") + n->health_message();
  }
  if (stopping_) worst = Health::kStopping;
  if (s.decode_errors > 0 && worst == Health::kOk) {
    worst = Health::kDegraded;
    message += (message.empty() ? "" : "; ") + std::to_string(s.decode_errors) + " malformed messages dropped";
  }
  if (handler_errors > 0 && worst == Health::kOk) {
    worst = Health::kDegraded;
    message += (message.empty() ? "" : "; ") + std::to_string(handler_errors) + " messages failed in a handler";
  }
  s.state = static_cast<int8_t>(worst);
  s.message = message;
  s.num_counters = static_cast<int32_t>(s.counter_names.size());
  publish(channels::kProcessStatus, s);
}

}  // namespace harvest::rt
