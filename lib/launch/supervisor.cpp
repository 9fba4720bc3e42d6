#include "launch/supervisor.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <system_error>

#include "runtime/channels.hpp"

namespace harvest::launch {

namespace {
rt::Micros micros(double s) { return static_cast<rt::Micros>(s * 1e6); }
constexpr rt::Micros kRecorderSettle = 300 * rt::kMilli;
}  // namespace

const char* phase_name(Phase p) {
  switch (p) {
    case Phase::kWaiting: return "waiting";
    case Phase::kRunning: return "running";
    case Phase::kBackoff: return "restarting";
    case Phase::kExited: return "exited";
    case Phase::kFailed: return "FAILED";
    case Phase::kStopping: return "stopping";
    case Phase::kStopped: return "stopped";
  }
  return "?";
}

const char* action_name(OrderAction a) {
  switch (a) {
    case OrderAction::kStart: return "start";
    case OrderAction::kStop: return "stop";
    case OrderAction::kRestart: return "restart";
  }
  return "?";
}

Supervisor::Supervisor(SetSpec set, SupervisorOptions options, Console& console, std::string timestamp)
    : rt::Node("supervisor"), set_(std::move(set)), options_(std::move(options)), console_(console) {
  log_health_changes(false);  // every problem the health names was said on the console already
  std::map<std::string, std::string> common_env;
  if (!set_.lcm_url.empty()) common_env["LCM_DEFAULT_URL"] = set_.lcm_url;
  if (set_.recording.enabled) {
    // The recorder starts first so it sees every CONFIG message, and stops last.
    Managed r;
    r.spec.name = "recorder";
    r.spec.command = set_.recording.logger;
    r.spec.group = options_.group.empty() ? "default" : options_.group;
    r.spec.cwd = set_.file.parent_path();
    r.spec.critical = true;  // a run that is not recorded is not what was asked for
    r.spec.heartbeat_timeout_s = 0;
    r.spec.stop_timeout_s = 5;
    r.argv = recorder_command_line(set_, timestamp);
    r.env = common_env;
    r.stop_signal = SIGINT;  // harvest-record and lcm-logger flush and close their file on SIGINT
    r.recorder = true;
    procs_.push_back(std::move(r));
  }
  for (std::size_t i : select_group(set_, options_.group)) {
    Managed m;
    m.spec = set_.processes[i];
    m.argv = command_line(set_, m.spec);
    m.env = common_env;
    for (const auto& [k, v] : m.spec.env) m.env[k] = v;
    procs_.push_back(std::move(m));
  }
  // Forked before any child; the grace is the longest stop a process asked for.
  double grace_s = 1;
  for (const auto& m : procs_) grace_s = std::max(grace_s, m.spec.stop_timeout_s);
  guardian_ = std::make_unique<Guardian>(std::chrono::milliseconds(static_cast<int64_t>(grace_s * 1000)));
}

Supervisor::~Supervisor() {
  for (auto& m : procs_) {
    if (m.pid > 0) {
      signal_group(m.pid, SIGKILL);
      int st = 0;
      waitpid(m.pid, &st, 0);
      guardian_->forget(m.pid);
    }
    if (m.fd >= 0) close(m.fd);
  }
}

void Supervisor::on_attach() {
  subscribe<harvest::process_status_t>(channels::kProcessStatus,
                                       [this](const harvest::process_status_t& s) { on_status(s); });
  for (auto& m : procs_) m.waiting_since = now();
  every(options_.poll_period, [this] { tick(); });
  every(options_.table_period, [this] { refresh(); });
  say("set '" + set_.name + "' (" + set_.file.string() + "): " + std::to_string(procs_.size()) + " processes" +
      (options_.group.empty() ? "" : " in group " + options_.group));
  tick();
}

void Supervisor::tick() {
  reap();
  if (shutting_down_) {
    advance_shutdown();
    return;
  }
  start_due();
  check_ordered_stops();
  check_heartbeats();
}

void Supervisor::say(const std::string& text) {
  console_.line("launch", text);
  if (tap_) tap_("launch", text);
}

void Supervisor::start(Managed& m) {
  try {
    const Spawned s = spawn(m.argv, m.env, m.spec.cwd);
    m.pid = s.pid;
    m.fd = s.output_fd;
    guardian_->watch(m.pid, m.stop_signal);
  } catch (const std::system_error& e) {
    say(m.spec.name + ": cannot start: " + e.what());
    on_exit(m, 127);
    return;
  }
  m.phase = Phase::kRunning;
  m.started = now();
  m.last_beat = -1;
  m.heartbeat_lost = false;
  m.reported_state = -1;
  m.reported_message.clear();
  std::string cmd;
  for (const auto& a : m.argv) cmd += (cmd.empty() ? "" : " ") + a;
  say("started " + m.spec.name + " (pid " + std::to_string(m.pid) + "): " + cmd);
  ctx().watch_fd(m.fd, [this, &m] { drain_output(m); });
}

void Supervisor::drain_output(Managed& m) {
  if (m.fd < 0) return;
  char buf[4096];
  auto emit = [this, &m](const std::string& l) {
    console_.line(m.spec.name, l);
    if (tap_) tap_(m.spec.name, l);
    if (m.recorder) m.reported_message = l;  // the table shows its last size/rate report
  };
  for (;;) {
    const ssize_t n = read(m.fd, buf, sizeof buf);
    if (n > 0) {
      m.output.feed(buf, static_cast<std::size_t>(n), emit);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
    // End of file: the process (and everything it started) closed the pipe.
    m.output.flush(emit);
    ctx().unwatch_fd(m.fd);
    close(m.fd);
    m.fd = -1;
    return;
  }
}

void Supervisor::reap() {
  for (auto& m : procs_) {
    if (m.pid <= 0) continue;
    int status = 0;
    if (waitpid(m.pid, &status, WNOHANG) != m.pid) continue;
    drain_output(m);
    // Whatever the process left behind in its group goes with it: no orphans.
    signal_group(m.pid, SIGKILL);
    guardian_->forget(m.pid);
    m.pid = -1;
    on_exit(m, exit_code_of(status));
  }
}

void Supervisor::on_exit(Managed& m, int code) {
  m.last_exit = code;
  const std::string how =
      code > 128 ? "killed by signal " + std::to_string(code - 128) : "exited with code " + std::to_string(code);
  if (shutting_down_) {
    m.phase = Phase::kStopped;
    say(m.spec.name + " stopped (" + how + ")");
    return;
  }
  say(m.spec.name + " " + how + " after " + seconds_text(now() - m.started));
  if (m.ordered) {
    // Stopped on an order: neither its restart policy nor ends_set nor critical applies.
    const OrderAction a = *m.ordered;
    m.ordered.reset();
    if (a == OrderAction::kRestart) {
      ++m.total_restarts;
      count("restarts." + m.spec.name);
      m.restarts = 0;
      start(m);
    } else {
      m.phase = Phase::kStopped;
    }
    return;
  }
  const bool named = !options_.exit_with.empty() && m.spec.name == options_.exit_with;
  if (named || m.spec.ends_set) {
    m.phase = Phase::kExited;
    say("stopping the set: " + m.spec.name + " exited (" + (named ? "--exit-with" : "ends_set") + ")");
    ctx().request_stop(code);
    return;
  }
  if (now() - m.started >= micros(m.spec.restart.reset_after_s)) m.restarts = 0;
  const bool failed = code != 0;
  if (const auto delay = restart_delay(m.spec.restart, m.restarts, failed)) {
    ++m.restarts;
    ++m.total_restarts;
    count("restarts." + m.spec.name);
    m.phase = Phase::kBackoff;
    m.restart_at = now() + micros(*delay);
    say("restarting " + m.spec.name + " in " + seconds_text(micros(*delay)) + " (restart " +
        std::to_string(m.restarts) +
        (m.spec.restart.max_restarts >= 0 ? " of " + std::to_string(m.spec.restart.max_restarts) : "") + ")");
    return;
  }
  m.phase = failed ? Phase::kFailed : Phase::kExited;
  if (failed && m.spec.critical) {
    say("critical process " + m.spec.name + " failed and will not be restarted: stopping the set");
    set_health(rt::Health::kError, m.spec.name + " failed");
    ctx().request_stop(1);
  }
}

bool Supervisor::ready(const std::string& name) const {
  for (const auto& m : procs_) {
    if (m.spec.name != name || m.recorder) continue;
    if (m.phase == Phase::kExited && m.last_exit == 0) return true;  // one-shot steps (calibration)
    if (m.phase != Phase::kRunning) return false;
    return m.spec.heartbeat_timeout_s == 0 || m.last_beat >= 0 || now() - m.started >= micros(m.spec.ready_timeout_s);
  }
  return true;  // in another host group: started on another machine
}

void Supervisor::start_due() {
  for (auto& m : procs_) {
    if (m.phase == Phase::kBackoff && now() >= m.restart_at) {
      start(m);
    } else if (m.phase == Phase::kWaiting) {
      // The recorder has no heartbeat: give it a moment to subscribe so it sees every CONFIG message.
      const Managed& rec = procs_.front();
      if (!m.recorder && rec.recorder && (rec.phase != Phase::kRunning || now() - rec.started < kRecorderSettle))
        continue;
      if (std::all_of(m.spec.after.begin(), m.spec.after.end(), [this](const std::string& d) { return ready(d); }))
        start(m);
    }
  }
}

OrderResult Supervisor::order(const std::string& process, OrderAction action) {
  const std::string what = std::string(action_name(action)) + " " + process;
  if (shutting_down_) return {false, what + ": refused, the set is stopping"};
  auto it = std::find_if(procs_.begin(), procs_.end(), [&](const Managed& m) { return m.spec.name == process; });
  if (it == procs_.end()) return {false, what + ": no such process here"};
  Managed& m = *it;
  if (action == OrderAction::kStart) {
    if (m.phase == Phase::kRunning || m.phase == Phase::kStopping)
      return {false, what + ": refused, it is " + phase_name(m.phase) + " (pid " + std::to_string(m.pid) + ")"};
    m.restarts = 0;
    say("ordered: " + what);
    start(m);
    return {m.phase == Phase::kRunning,
            what + (m.phase == Phase::kRunning ? ": started, pid " + std::to_string(m.pid) : ": could not start")};
  }
  if (m.pid <= 0) {
    // Not running: a stop just keeps it down; a restart starts it now.
    if (action == OrderAction::kStop) {
      m.phase = Phase::kStopped;
      say("ordered: " + what + " (was not running)");
      return {true, what + ": stopped (was not running)"};
    }
    m.restarts = 0;
    ++m.total_restarts;
    say("ordered: " + what + " (was not running)");
    start(m);
    return {m.phase == Phase::kRunning, what + ": started, pid " + std::to_string(m.pid)};
  }
  if (m.ordered) return {false, what + ": refused, a " + action_name(*m.ordered) + " is under way"};
  say("ordered: " + what + " (pid " + std::to_string(m.pid) + ")");
  m.ordered = action;
  m.phase = Phase::kStopping;
  m.kill_at = now() + micros(m.spec.stop_timeout_s);
  signal_group(m.pid, m.stop_signal);
  return {true, what + ": stopping pid " + std::to_string(m.pid)};
}

void Supervisor::check_ordered_stops() {
  for (auto& m : procs_) {
    if (!m.ordered || m.pid <= 0 || m.kill_at == 0 || now() < m.kill_at) continue;
    say(m.spec.name + " did not stop within " + seconds_text(micros(m.spec.stop_timeout_s)) + ": SIGKILL");
    signal_group(m.pid, SIGKILL);
    m.kill_at = 0;  // reaped on a later tick
  }
}

void Supervisor::check_heartbeats() {
  for (auto& m : procs_) {
    if (m.phase != Phase::kRunning || m.spec.heartbeat_timeout_s <= 0) continue;
    const rt::Micros age = now() - (m.last_beat >= 0 ? m.last_beat : m.started);
    if (!m.heartbeat_lost && age > micros(m.spec.heartbeat_timeout_s)) {
      m.heartbeat_lost = true;
      count("heartbeats_lost");
      say(m.spec.name + ": heartbeat lost (no PROCESS_STATUS for " + seconds_text(age) + ")");
    }
  }
}

void Supervisor::on_status(const harvest::process_status_t& s) {
  if (s.instance == options_.own_instance) return;
  for (auto& m : procs_) {
    if (m.spec.name != s.instance || m.phase != Phase::kRunning) continue;
    if (m.heartbeat_lost) say(m.spec.name + ": heartbeat back");
    m.heartbeat_lost = false;
    m.last_beat = now();
    m.reported_state = s.state;
    m.reported_message = s.message;
  }
}

void Supervisor::begin_shutdown() {
  if (shutting_down_) return;
  shutting_down_ = true;
  say("stopping the set");
  // Stage 1: the processes that move the arm, together; then the rest one by
  // one in reverse start order; the recorder last so it sees everything.
  std::vector<std::size_t> first, rest;
  for (std::size_t i = procs_.size(); i-- > 0;) {
    Managed& m = procs_[i];
    if (m.phase == Phase::kWaiting || m.phase == Phase::kBackoff) m.phase = Phase::kStopped;
    if (m.recorder) continue;
    (m.spec.stop_first ? first : rest).push_back(i);
  }
  if (!first.empty()) stop_stages_.push_back(first);
  for (std::size_t i : rest) stop_stages_.push_back({i});
  if (!procs_.empty() && procs_.front().recorder) stop_stages_.push_back({0});
  stage_ = 0;
  stage_signalled_ = false;
  advance_shutdown();
}

void Supervisor::advance_shutdown() {
  while (stage_ < stop_stages_.size()) {
    auto& stage = stop_stages_[stage_];
    const bool alive = std::any_of(stage.begin(), stage.end(), [this](std::size_t i) { return procs_[i].pid > 0; });
    if (!alive) {
      ++stage_;
      stage_signalled_ = false;
      continue;
    }
    if (!stage_signalled_) {
      rt::Micros timeout = 0;
      for (std::size_t i : stage) {
        Managed& m = procs_[i];
        if (m.pid <= 0) continue;
        m.phase = Phase::kStopping;
        signal_group(m.pid, m.stop_signal);
        timeout = std::max(timeout, micros(m.spec.stop_timeout_s));
      }
      stage_deadline_ = now() + timeout;
      stage_signalled_ = true;
      return;
    }
    if (now() < stage_deadline_) return;
    for (std::size_t i : stage) {
      Managed& m = procs_[i];
      if (m.pid <= 0) continue;
      say(m.spec.name + " did not stop within " + seconds_text(micros(m.spec.stop_timeout_s)) + ": SIGKILL");
      signal_group(m.pid, SIGKILL);
    }
    return;  // reaped on the next tick
  }
}

bool Supervisor::shutdown_complete() const {
  return std::none_of(procs_.begin(), procs_.end(), [](const Managed& m) { return m.pid > 0; });
}

rt::Micros Supervisor::shutdown_budget() const {
  rt::Micros total = rt::kSecond;
  for (const auto& m : procs_) total += micros(m.spec.stop_timeout_s) + 200 * rt::kMilli;
  return total;
}

std::vector<StatusRow> Supervisor::rows() const {
  std::vector<StatusRow> out;
  for (const auto& m : procs_) {
    StatusRow r;
    r.name = m.spec.name;
    r.group = m.spec.group;
    r.state = phase_name(m.phase);
    if (m.phase == Phase::kRunning && m.heartbeat_lost) r.state = "NO HEARTBEAT";
    r.pid = m.pid;
    r.restarts = m.total_restarts;
    if (m.last_exit) r.last_exit = std::to_string(*m.last_exit);
    if (m.spec.heartbeat_timeout_s <= 0)
      r.heartbeat = "-";
    else if (m.last_beat < 0)
      r.heartbeat = "none yet";
    else {
      r.heartbeat = seconds_text(now() - m.last_beat);
      r.heartbeat_age_s = rt::to_seconds(now() - m.last_beat);
    }
    r.message = m.reported_message;
    out.push_back(std::move(r));
  }
  return out;
}

void Supervisor::refresh() {
  // The set's health is the worst of its processes', with the reason.
  std::string problems;
  rt::Health h = rt::Health::kOk;
  auto note = [&](rt::Health level, const std::string& what) {
    if (static_cast<int>(level) > static_cast<int>(h)) h = level;
    problems += (problems.empty() ? "" : "; ") + what;
  };
  for (const auto& m : procs_) {
    if (m.phase == Phase::kFailed)
      note(m.spec.critical ? rt::Health::kError : rt::Health::kDegraded, m.spec.name + " failed");
    else if (m.phase == Phase::kBackoff)
      note(rt::Health::kDegraded, m.spec.name + " restarting");
    else if (m.heartbeat_lost)
      note(rt::Health::kDegraded, m.spec.name + " heartbeat lost");
    else if (m.reported_state == harvest::process_status_t::STATE_ERROR)
      note(rt::Health::kDegraded, m.spec.name + " reports error");
  }
  if (shutting_down_) h = rt::Health::kStopping;
  set_health(h, problems);
  console_.table(render_table(rows()));
}

}  // namespace harvest::launch
