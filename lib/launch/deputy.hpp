// A deputy: the launcher of one host seen from the others (docs/launcher.md
// "Several hosts"), after procman's deputy. It publishes its processes'
// status (DEPUTY_STATUS, every status_period and at once after an order) and
// their output lines (DEPUTY_OUTPUT, batched, rate-limited, each line cut at
// max_line), and obeys LAUNCH_ORDER addressed to it when an operator signed it
// (docs/security.md): start, stop or restart one process. An order that is
// unsigned, wrongly signed, stale or replayed is refused and counted
// (launch_order_refused on PROCESS_STATUS, orders_refused in its status).
#pragma once

#include <deque>
#include <functional>
#include <harvest/deputy_status_t.hpp>
#include <harvest/launch_order_t.hpp>
#include <map>
#include <string>
#include <vector>

#include "launch/proc_usage.hpp"
#include "launch/supervisor.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::launch {

struct DeputyOptions {
  std::string name;  // what orders are addressed to (--deputy)
  std::string host;  // gethostname
  int pid = 0;
  std::string set_name;
  std::string groups;                   // comma-separated
  security::AuthorityConfig authority;  // key and the operators it obeys
  rt::Micros status_period = rt::kSecond;
  rt::Micros output_period = 100 * rt::kMilli;
  // Output forwarding: a token bucket, `lines_per_s` sustained, `burst` at
  // once; lines beyond it are dropped and counted, so a chatty process
  // cannot flood the network (the lines still reach the deputy's terminal).
  double lines_per_s = 200;
  double burst = 400;
  std::size_t max_line = 256;
  std::size_t last_lines = 3;  // kept per process for the status
  // How CPU and memory are read (tests replace it).
  std::function<ProcUsage(int pid)> usage = [](int pid) { return read_proc_usage(pid); };
};

class Deputy final : public rt::Node {
 public:
  Deputy(LaunchedSet& set, DeputyOptions options, const security::Key& key);

  harvest::deputy_status_t status() const;

 private:
  void on_attach() override;
  void on_order(const harvest::launch_order_t& order);
  void on_line(const std::string& source, const std::string& line);
  void publish_status();
  void flush_output();
  void sample_usage();

  LaunchedSet& set_;
  DeputyOptions options_;
  security::Authority authority_;
  bool attached_ = false;

  int64_t obeyed_ = 0;
  int64_t last_order_seq_ = 0;
  bool last_order_done_ = false;
  std::string last_order_result_;

  struct Usage {
    int pid = -1;
    ProcUsage at;
    rt::Micros time = 0;
    double cpu_percent = -1;
  };
  std::map<std::string, Usage> usage_;
  std::map<std::string, std::deque<std::string>> last_lines_;

  double tokens_;
  rt::Micros refilled_ = 0;
  std::vector<std::pair<std::string, std::string>> pending_;
  int64_t dropped_pending_ = 0, dropped_total_ = 0;
};

}  // namespace harvest::launch
