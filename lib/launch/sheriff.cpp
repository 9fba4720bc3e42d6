#include "launch/sheriff.hpp"

#include <algorithm>
#include <harvest/launch_order_t.hpp>
#include <stdexcept>

#include "runtime/channels.hpp"

namespace harvest::launch {

namespace {
const harvest::deputy_process_t* find(const harvest::deputy_status_t& s, const std::string& name) {
  for (const auto& p : s.processes)
    if (p.name == name) return &p;
  return nullptr;
}
std::string pid_text(int pid) { return pid > 0 ? "pid " + std::to_string(pid) : "no pid"; }
}  // namespace

SheriffOrder parse_target(const std::string& target, OrderAction action) {
  const auto slash = target.find('/');
  if (slash == std::string::npos || slash == 0 || slash + 1 == target.size() ||
      target.find('/', slash + 1) != std::string::npos)
    throw std::invalid_argument("'" + target + "' is not DEPUTY/PROCESS");
  return SheriffOrder{target.substr(0, slash), target.substr(slash + 1), action};
}

Sheriff::Sheriff(SheriffOptions options, Console& console, const security::Key& key)
    : rt::Node("sheriff"), options_(std::move(options)), console_(console), signer_(key, options_.sender, clock()) {}

void Sheriff::on_attach() {
  started_ = now();
  subscribe<harvest::deputy_status_t>(channels::kDeputyStatus,
                                      [this](const harvest::deputy_status_t& s) { on_status(s); });
  if (options_.print_output)
    subscribe<harvest::deputy_output_t>(channels::kDeputyOutput,
                                        [this](const harvest::deputy_output_t& o) { on_output(o); });
  if (options_.order) advertise(channels::kLaunchOrder);
  every(100 * rt::kMilli, [this] { tick(); });
  if (!options_.order && !options_.list_after)
    every(options_.table_period, [this] { console_.table(render_table(rows())); });
}

void Sheriff::on_status(const harvest::deputy_status_t& s) {
  auto [it, fresh] = deputies_.try_emplace(s.deputy);
  Seen& seen = it->second;
  const bool quiet = options_.order.has_value();  // an order's run says only what concerns the order
  if (fresh) {
    if (!quiet)
      say("deputy " + s.deputy + " on " + s.host + " (pid " + std::to_string(s.pid) + "): set " + s.set_name +
          ", groups " + s.groups + ", " + std::to_string(s.num_processes) + " processes");
  } else {
    if (seen.lost && !quiet) say("deputy " + s.deputy + " is back");
    if (s.orders_refused > seen.status.orders_refused)
      say("deputy " + s.deputy + " refused " + std::to_string(s.orders_refused - seen.status.orders_refused) +
          " order(s) (" + std::to_string(s.orders_refused) +
          " so far): unsigned, signed with another key or sender, stale or replayed");
  }
  if (!quiet)
    for (const auto& p : s.processes) {
      const harvest::deputy_process_t* before = fresh ? nullptr : find(seen.status, p.name);
      if (before == nullptr || before->state != p.state || before->pid != p.pid)
        say(s.deputy + "/" + p.name + " " + p.state + " (" + pid_text(p.pid) + ")");
    }
  seen.status = s;
  seen.at = now();
  seen.lost = false;
  if (options_.order && s.deputy == options_.order->deputy) advance_order(s);
}

void Sheriff::on_output(const harvest::deputy_output_t& o) {
  for (int i = 0; i < o.num_lines; ++i) console_.line(o.deputy + "/" + o.source[i], o.line[i]);
  if (o.dropped > 0) say("deputy " + o.deputy + " dropped " + std::to_string(o.dropped) + " output lines (rate limit)");
}

void Sheriff::tick() {
  for (auto& [name, seen] : deputies_) {
    if (!seen.lost && now() - seen.at > options_.lost_after) {
      seen.lost = true;
      say("deputy " + name + " lost (no status for " + seconds_text(now() - seen.at) + ")");
    }
  }
  if (options_.list_after && now() - started_ >= *options_.list_after) {
    ctx().request_stop(deputies_.empty() ? 1 : 0);
    return;
  }
  if (!options_.order || step_ == Step::kDone) return;
  const SheriffOrder& o = *options_.order;
  const std::string target = o.deputy + "/" + o.process;
  if (now() - started_ > options_.order_timeout) {
    if (step_ == Step::kWaitDeputy)
      finish(1, "no status from deputy " + o.deputy + " in " + seconds_text(options_.order_timeout));
    else if (step_ == Step::kWaitAck)
      finish(1, "deputy " + o.deputy + " did not acknowledge the " + action_name(o.action) + " of " + target +
                    (deputies_[o.deputy].status.orders_refused > refused_at_send_
                         ? ": it refused the order (the key or sender is not one it obeys: docs/security.md)"
                         : ""));
    else
      finish(1, target + " did not reach the ordered state in " + seconds_text(options_.order_timeout));
    return;
  }
  if (step_ == Step::kWaitAck && now() - sent_at_ >= options_.resend_after) send_order();
}

void Sheriff::send_order() {
  const SheriffOrder& o = *options_.order;
  harvest::launch_order_t msg{};
  msg.header.utime = now();
  msg.header.frame_id = o.deputy;
  msg.header.source_seq = -1;
  msg.deputy = o.deputy;
  msg.process = o.process;
  msg.action = o.action == OrderAction::kStart  ? harvest::launch_order_t::START
               : o.action == OrderAction::kStop ? harvest::launch_order_t::STOP
                                                : harvest::launch_order_t::RESTART;
  msg.source = options_.source;
  publish(channels::kLaunchOrder, msg, [this](harvest::launch_order_t& m) { signer_.sign(m); });
  sent_seqs_.push_back(msg.auth.seq);
  sent_at_ = now();
  step_ = Step::kWaitAck;
}

void Sheriff::advance_order(const harvest::deputy_status_t& s) {
  const SheriffOrder& o = *options_.order;
  const std::string target = o.deputy + "/" + o.process;
  const harvest::deputy_process_t* p = find(s, o.process);
  if (step_ == Step::kWaitDeputy) {
    if (p == nullptr) {
      std::string names;
      for (const auto& q : s.processes) names += (names.empty() ? "" : ", ") + q.name;
      finish(2, "deputy " + o.deputy + " has no process " + o.process + " (it runs: " + names + ")");
      return;
    }
    old_pid_ = p->pid;
    refused_at_send_ = s.orders_refused;
    send_order();
    return;
  }
  if (step_ == Step::kWaitAck) {
    if (std::find(sent_seqs_.begin(), sent_seqs_.end(), s.last_order_seq) == sent_seqs_.end()) return;
    if (!s.last_order_done) {
      finish(1, "deputy " + o.deputy + ": " + s.last_order_result);
      return;
    }
    say("deputy " + o.deputy + ": " + s.last_order_result);
    step_ = Step::kWaitState;
  }
  if (step_ != Step::kWaitState || p == nullptr) return;
  const bool running = p->state == "running" && p->pid > 0;
  switch (o.action) {
    case OrderAction::kStop:
      if (p->pid <= 0) finish(0, "stopped " + target + " (was " + pid_text(old_pid_) + ")");
      break;
    case OrderAction::kStart:
      if (running) finish(0, "started " + target + ": " + pid_text(p->pid));
      break;
    case OrderAction::kRestart:
      if (running && p->pid != old_pid_)
        finish(0, "restarted " + target + ": " + pid_text(old_pid_) + " -> " + pid_text(p->pid));
      break;
  }
}

void Sheriff::finish(int code, const std::string& text) {
  say(text);
  step_ = Step::kDone;
  ctx().request_stop(code);
}

std::vector<StatusRow> Sheriff::rows() const {
  std::vector<StatusRow> out;
  for (const auto& [name, seen] : deputies_) {
    for (const auto& p : seen.status.processes) {
      StatusRow r;
      r.host = name;
      r.name = p.name;
      r.group = p.group;
      r.state = seen.lost ? "DEPUTY LOST" : p.state;
      r.pid = p.pid;
      r.restarts = p.restarts;
      if (p.last_exit >= 0) r.last_exit = std::to_string(p.last_exit);
      r.heartbeat_age_s = p.heartbeat_age_s;
      if (p.heartbeat_age_s >= 0)
        r.heartbeat = seconds_text(static_cast<rt::Micros>(p.heartbeat_age_s * 1e6));
      else
        r.heartbeat = "-";
      r.message = p.message;
      if (r.message.empty() && !p.last_lines.empty()) r.message = p.last_lines.back();
      r.cpu_percent = p.cpu_percent;
      r.rss_bytes = p.rss_bytes;
      out.push_back(std::move(r));
    }
  }
  return out;
}

}  // namespace harvest::launch
