// The launcher as a node: starts the processes of a set in dependency order,
// forwards their output, watches exit codes and heartbeats (PROCESS_STATUS),
// restarts per policy, and on shutdown stops the `stop_first` processes (the
// arm) before the rest in reverse start order, SIGKILL after each timeout.
//
// Unlike processing nodes it is live-only: it forks and signals processes.
// Its time still comes from now() and its polling from every(), and its
// health (published by the heartbeat node next to it) summarises the set.
#pragma once

#include <sys/types.h>

#include <harvest/process_status_t.hpp>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "launch/child.hpp"
#include "launch/console.hpp"
#include "launch/guardian.hpp"
#include "launch/set_spec.hpp"
#include "runtime/node.hpp"

namespace harvest::launch {

struct SupervisorOptions {
  std::string group;      // host group to start; empty: all
  std::string exit_with;  // stop the set when this process exits, with its exit code
  std::string own_instance = "launch";
  rt::Micros poll_period = 50 * rt::kMilli;
  rt::Micros table_period = rt::kSecond;
};

enum class Phase { kWaiting, kRunning, kBackoff, kExited, kFailed, kStopping, kStopped };
const char* phase_name(Phase p);

// An order to one process of the set (a deputy obeys the sheriff's; docs/launcher.md).
enum class OrderAction { kStart, kStop, kRestart };
const char* action_name(OrderAction a);
struct OrderResult {
  bool done = false;  // false: refused (no such process, already running, shutting down)
  std::string text;   // what was done or why not
};

// What a deputy needs of the launcher: its table, orders, and its output.
class LaunchedSet {
 public:
  virtual ~LaunchedSet() = default;
  virtual std::vector<StatusRow> rows() const = 0;
  virtual OrderResult order(const std::string& process, OrderAction action) = 0;
  // Called with every output line of a process (source = its name) and every
  // line of the launcher's own news (source "launch").
  using OutputTap = std::function<void(const std::string& source, const std::string& line)>;
  virtual void set_output_tap(OutputTap tap) = 0;
};

class Supervisor final : public rt::Node, public LaunchedSet {
 public:
  Supervisor(SetSpec set, SupervisorOptions options, Console& console, std::string timestamp);
  ~Supervisor() override;  // SIGKILLs whatever is still running

  void begin_shutdown() override;
  bool shutdown_complete() const override;

  // Longest a clean shutdown can take (sum of the stop stages' timeouts).
  rt::Micros shutdown_budget() const;
  std::vector<StatusRow> rows() const override;
  // Stop: the stop signal, SIGKILL after stop_timeout_s, then left stopped
  // (no restart policy, no ends_set, a critical one does not stop the set).
  // Restart: the same stop, then started at once. Start: one that is stopped,
  // exited or failed, or waiting for its dependencies.
  OrderResult order(const std::string& process, OrderAction action) override;
  void set_output_tap(OutputTap tap) override { tap_ = std::move(tap); }

 private:
  struct Managed {
    ProcessSpec spec;
    std::vector<std::string> argv;
    std::map<std::string, std::string> env;
    int stop_signal = 15;
    bool recorder = false;
    Phase phase = Phase::kWaiting;
    pid_t pid = -1;
    int fd = -1;
    LineBuffer output;
    int restarts = 0;  // in a row, reset after a long enough run
    int total_restarts = 0;
    std::optional<int> last_exit;
    rt::Micros started = 0, restart_at = 0, last_beat = -1, waiting_since = 0;
    bool heartbeat_lost = false;
    int8_t reported_state = -1;
    std::string reported_message;
    std::optional<OrderAction> ordered;  // a stop or restart ordered and not yet done
    rt::Micros kill_at = 0;              // SIGKILL then, if an ordered stop is not done
  };

  void on_attach() override;
  void tick();
  void start(Managed& m);
  void drain_output(Managed& m);
  void reap();
  void on_exit(Managed& m, int code);
  bool ready(const std::string& name) const;
  void start_due();
  void check_heartbeats();
  void on_status(const harvest::process_status_t& s);
  void advance_shutdown();
  void refresh();
  void check_ordered_stops();
  void say(const std::string& text);

  SetSpec set_;
  SupervisorOptions options_;
  Console& console_;
  std::vector<Managed> procs_;  // recorder first, then start order
  bool shutting_down_ = false;
  std::vector<std::vector<std::size_t>> stop_stages_;
  std::size_t stage_ = 0;
  bool stage_signalled_ = false;
  rt::Micros stage_deadline_ = 0;
  // Stops every group still running if this process dies without doing so.
  std::unique_ptr<Guardian> guardian_;
  OutputTap tap_;
};

}  // namespace harvest::launch
