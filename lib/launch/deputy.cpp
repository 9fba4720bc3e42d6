#include "launch/deputy.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <harvest/deputy_output_t.hpp>

#include "runtime/channels.hpp"

namespace harvest::launch {

Deputy::Deputy(LaunchedSet& set, DeputyOptions options, const security::Key& key)
    : rt::Node("deputy"),
      set_(set),
      options_(std::move(options)),
      authority_(options_.authority, key, clock(), [this](const std::string& c, int64_t n) { count(c, n); }),
      tokens_(options_.burst) {
  set_.set_output_tap([this](const std::string& source, const std::string& line) { on_line(source, line); });
}

void Deputy::on_attach() {
  attached_ = true;
  refilled_ = now();
  advertise(channels::kDeputyStatus);
  advertise(channels::kDeputyOutput);
  subscribe<harvest::launch_order_t>(channels::kLaunchOrder, [this](const harvest::launch_order_t& o) { on_order(o); });
  every(options_.status_period, [this] {
    sample_usage();
    publish_status();
  });
  every(options_.output_period, [this] { flush_output(); });
  spdlog::info("deputy '{}': obeys LAUNCH_ORDER signed with {}", options_.name, authority_.describe());
}

void Deputy::on_order(const harvest::launch_order_t& o) {
  if (o.deputy != options_.name) return;  // another deputy's
  if (!authority_.admit_from_operator("LAUNCH_ORDER", o)) {
    publish_status();  // the sheriff sees the refusal count at once
    return;
  }
  OrderResult r;
  switch (o.action) {
    case harvest::launch_order_t::START:
      r = set_.order(o.process, OrderAction::kStart);
      break;
    case harvest::launch_order_t::STOP:
      r = set_.order(o.process, OrderAction::kStop);
      break;
    case harvest::launch_order_t::RESTART:
      r = set_.order(o.process, OrderAction::kRestart);
      break;
    default:
      r = {false, "unknown action " + std::to_string(o.action)};
  }
  ++obeyed_;
  count("orders_obeyed");
  last_order_seq_ = o.auth.seq;
  last_order_done_ = r.done;
  last_order_result_ = r.text;
  spdlog::info("order from {} ({}): {}", o.auth.sender, o.source, r.text);
  publish_status();
}

void Deputy::on_line(const std::string& source, const std::string& text) {
  const std::string line = text.size() > options_.max_line ? text.substr(0, options_.max_line) : text;
  auto& last = last_lines_[source];
  last.push_back(line);
  while (last.size() > options_.last_lines) last.pop_front();
  if (attached_) {
    tokens_ = std::min(options_.burst, tokens_ + options_.lines_per_s * rt::to_seconds(now() - refilled_));
    refilled_ = now();
  }
  if (tokens_ < 1) {
    ++dropped_pending_;
    ++dropped_total_;
    count("output_dropped");
    return;
  }
  tokens_ -= 1;
  pending_.emplace_back(source, line);
}

void Deputy::flush_output() {
  if (pending_.empty() && dropped_pending_ == 0) return;
  harvest::deputy_output_t out{};
  out.header.utime = now();
  out.header.frame_id = options_.name;
  out.header.source_seq = -1;
  out.deputy = options_.name;
  for (auto& [source, line] : pending_) {
    out.source.push_back(std::move(source));
    out.line.push_back(std::move(line));
  }
  out.num_lines = static_cast<int32_t>(out.line.size());
  out.dropped = dropped_pending_;
  pending_.clear();
  dropped_pending_ = 0;
  publish(channels::kDeputyOutput, out);
}

void Deputy::sample_usage() {
  for (const auto& row : set_.rows()) {
    Usage& u = usage_[row.name];
    if (row.pid <= 0) {
      u = Usage{};
      continue;
    }
    const ProcUsage now_usage = options_.usage(row.pid);
    u.cpu_percent = u.pid == row.pid ? cpu_percent(u.at, now_usage, rt::to_seconds(now() - u.time)) : -1;
    u.pid = row.pid;
    u.at = now_usage;
    u.time = now();
  }
}

harvest::deputy_status_t Deputy::status() const {
  harvest::deputy_status_t s{};
  s.header.utime = now();
  s.header.frame_id = options_.name;
  s.header.source_seq = -1;
  s.deputy = options_.name;
  s.host = options_.host;
  s.pid = options_.pid;
  s.set_name = options_.set_name;
  s.groups = options_.groups;
  s.orders_obeyed = obeyed_;
  const auto& counters = stats().counters;
  const auto refused = counters.find("launch_order_refused");
  s.orders_refused = refused == counters.end() ? 0 : refused->second;
  s.last_order_seq = last_order_seq_;
  s.last_order_done = last_order_done_;
  s.last_order_result = last_order_result_;
  s.output_dropped = dropped_total_;
  for (const auto& row : set_.rows()) {
    harvest::deputy_process_t p{};
    p.name = row.name;
    p.group = row.group;
    p.state = row.state;
    p.pid = row.pid;
    p.restarts = row.restarts;
    p.last_exit = row.last_exit.empty() ? -1 : std::stoi(row.last_exit);
    p.heartbeat_age_s = static_cast<float>(row.heartbeat_age_s);
    p.message = row.message;
    const auto u = usage_.find(row.name);
    const bool measured = u != usage_.end() && u->second.pid == row.pid && row.pid > 0;
    p.cpu_percent = measured ? static_cast<float>(u->second.cpu_percent) : -1.0f;
    p.rss_bytes = measured ? u->second.at.rss_bytes : -1;
    const auto l = last_lines_.find(row.name);
    if (l != last_lines_.end()) p.last_lines.assign(l->second.begin(), l->second.end());
    p.num_lines = static_cast<int32_t>(p.last_lines.size());
    s.processes.push_back(std::move(p));
  }
  s.num_processes = static_cast<int32_t>(s.processes.size());
  return s;
}

void Deputy::publish_status() {
  auto s = status();
  publish(channels::kDeputyStatus, s);
}

}  // namespace harvest::launch
