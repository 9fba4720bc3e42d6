// The sheriff: one view of every deputy's processes (docs/launcher.md
// "Several hosts"), after procman's sheriff. It shows DEPUTY_STATUS of every
// host as one table (HOST column first), prints their forwarded output as
// "[host/process] line", says when a deputy appears, is lost or comes back
// and when a process changes state or pid; and sends one signed LAUNCH_ORDER
// (start, stop, restart host/process), waiting until the deputy acknowledged
// it and the process is in the ordered state.
#pragma once

#include <harvest/deputy_output_t.hpp>
#include <harvest/deputy_status_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "launch/console.hpp"
#include "launch/supervisor.hpp"
#include "runtime/node.hpp"
#include "security/auth.hpp"

namespace harvest::launch {

struct SheriffOrder {
  std::string deputy, process;
  OrderAction action = OrderAction::kRestart;
};
// "host/process" -> {host, process}; throws std::invalid_argument otherwise.
SheriffOrder parse_target(const std::string& target, OrderAction action);

struct SheriffOptions {
  rt::Micros lost_after = 3 * rt::kSecond;  // no DEPUTY_STATUS this long: the deputy is lost
  rt::Micros table_period = rt::kSecond;
  bool print_output = true;           // forwarded output lines
  std::optional<SheriffOrder> order;  // send it, wait, stop the runner: 0 done, 1 not, 2 no such process
  rt::Micros order_timeout = 20 * rt::kSecond;
  rt::Micros resend_after = 2500 * rt::kMilli;  // no acknowledgement (a lost datagram): sent again, newly signed
  std::optional<rt::Micros> list_after;         // stop the runner after this long (the CLI prints the table)
  std::string source;                           // who sends orders (user@host)
  std::string sender = "operator";              // id it signs as
};

class Sheriff final : public rt::Node {
 public:
  Sheriff(SheriffOptions options, Console& console, const security::Key& key);

  std::vector<StatusRow> rows() const;
  std::size_t deputies() const { return deputies_.size(); }

 private:
  struct Seen {
    harvest::deputy_status_t status;
    rt::Micros at = 0;
    bool lost = false;
  };

  void on_attach() override;
  void on_status(const harvest::deputy_status_t& s);
  void on_output(const harvest::deputy_output_t& o);
  void tick();
  void send_order();
  void advance_order(const harvest::deputy_status_t& s);
  void finish(int code, const std::string& text);
  void say(const std::string& text) { console_.line("sheriff", text); }

  SheriffOptions options_;
  Console& console_;
  security::Signer signer_;
  std::map<std::string, Seen> deputies_;
  rt::Micros started_ = 0;

  enum class Step { kWaitDeputy, kWaitAck, kWaitState, kDone };
  Step step_ = Step::kWaitDeputy;
  int old_pid_ = -1;
  std::vector<int64_t> sent_seqs_;  // every signing of the order (resent ones too)
  rt::Micros sent_at_ = 0;
  int64_t refused_at_send_ = -1;
};

}  // namespace harvest::launch
