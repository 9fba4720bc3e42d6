// harvest-operator: sends one operator command or emergency stop to the
// servo controller from the shell and waits for its acknowledgement
// (docs/servo-controller.md).
//
//   harvest-operator start|pause|resume|abort|home|reset-fault|estop|estop-clear
//                    [--source WHO] [--reason TEXT] [--lcm-url URL] [--prefix P] [--repeat N]
//                    [--timeout S] [--no-wait] [--key sim|FILE] [--sender ID]
// Commands go out signed (docs/security.md) with --key (default
// $HARVEST_COMMAND_KEY, else the simulator's key `sim`) as --sender
// (default `operator`, one of the receivers' authority.operators).
// Exit codes: 0 acknowledged (or sent, with --no-wait), 1 cannot publish,
// 2 bad command line, 3 nobody answered (no HARVEST_STATUS within --timeout),
// 4 refused by the controller, 5 the controller answers but did not
// acknowledge this command within --timeout.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <harvest/harvest_status_t.hpp>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <optional>

#include "runtime/channels.hpp"
#include "runtime/checked_subscription.hpp"
#include "security/authority.hpp"
#include "servo/operator_command.hpp"

namespace {

struct StatusListener {
  std::optional<harvest::harvest_status_t> latest;
  int received = 0;
  void on_status(const harvest::harvest_status_t& m) {
    latest = m;
    ++received;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Send an operator command or an emergency stop to the servo controller and wait for its reply"};
  std::string verb, source = harvest::servo::operator_source("harvest-operator"), reason, url, prefix;
  int repeat = 0;  // 0: three copies of an emergency stop, one of anything else
  double timeout_s = 2.0;
  bool no_wait = false;
  std::string key_name = harvest::security::default_command_key(), sender = "operator";
  app.add_option("command", verb, "start, pause, resume, abort, home, reset-fault, estop, estop-clear")
      ->required()
      ->check(CLI::IsMember(harvest::servo::operator_verbs()));
  app.add_option("--source", source, "who sends it (default user@host (harvest-operator PID))");
  app.add_option("--reason", reason, "reason, for estop");
  app.add_option("--lcm-url", url, "LCM provider URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_option("--prefix", prefix, "channel prefix of the arm's process graph");
  app.add_option("--repeat", repeat, "send this many copies 20 ms apart (default: 3 for estop verbs, else 1)")
      ->check(CLI::Range(1, 100));
  app.add_option("--timeout", timeout_s, "wait this long for the controller's acknowledgement [s]")
      ->check(CLI::Range(0.1, 60.0))
      ->capture_default_str();
  app.add_flag("--no-wait", no_wait, "send and exit without waiting for the acknowledgement");
  app.add_option("--key", key_name, "command key: 'sim' or the robot's key file (default $HARVEST_COMMAND_KEY or sim)");
  app.add_option("--sender", sender, "sender id it signs as (one of the receivers' authority.operators)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  harvest::rt::SystemClock clock;
  std::optional<harvest::security::Signer> signer;
  try {
    signer.emplace(harvest::security::load_named_key(key_name), sender, clock);
  } catch (const std::exception& e) {
    std::cerr << "harvest-operator: " << e.what() << "\n";
    return 2;
  }

  if (repeat == 0) repeat = harvest::servo::default_repeat(verb);

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << "harvest-operator: cannot open LCM (" << (url.empty() ? "default URL" : url) << ")\n";
    return 1;
  }
  // Listen before sending: the controller replies at once.
  StatusListener listener;
  harvest::rt::CheckedSubscription<harvest::harvest_status_t> status_sub(
      lcm, prefix + harvest::channels::kHarvestStatus,
      [&](const harvest::harvest_status_t& m) { listener.on_status(m); });

  const auto now_us =
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count();
  const auto msg = harvest::servo::make_operator_message(verb, source, reason, now_us);
  // An emergency stop goes out more than once: UDP multicast may drop a datagram.
  if (!harvest::servo::send_operator_message(lcm, prefix, msg, repeat, *signer)) {
    std::cerr << "harvest-operator: publish failed\n";
    return 1;
  }
  std::cout << "sent " << verb << " (" << repeat << "x) as " << source << std::endl;
  if (no_wait) return 0;

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  harvest::servo::Acknowledgement ack;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    if (lcm.handleTimeout(static_cast<int>(left.count())) <= 0 || !listener.latest) continue;
    ack = harvest::servo::acknowledgement(verb, source, *listener.latest);
    if (ack.state != harvest::servo::AckState::kWaiting) break;
  }
  switch (ack.state) {
    case harvest::servo::AckState::kAccepted:
      std::cout << verb << ": acknowledged by the servo controller: " << ack.detail << "\n";
      return 0;
    case harvest::servo::AckState::kRefused:
      std::cerr << "harvest-operator: " << verb << ": REFUSED by the servo controller: " << ack.detail << "\n";
      return 4;
    case harvest::servo::AckState::kWaiting:
      break;
  }
  if (listener.received == 0) {
    std::cerr << "harvest-operator: " << verb << ": nobody answered within " << timeout_s << " s (no " << prefix
              << harvest::channels::kHarvestStatus
              << " from a servo controller): is it running, on this LCM URL and prefix? (multicast route: "
                 "`tools/harvest netfix`)\n";
    return 3;
  }
  std::cerr << "harvest-operator: " << verb << ": the servo controller answers but did not acknowledge this command "
            << "within " << timeout_s << " s; its state: " << listener.latest->summary
            << " (a command signed with the wrong key or sender is refused without a reply: see the receivers' "
               "*_refused counters on PROCESS_STATUS; this one went out signed as '"
            << sender << "' with key " << key_name << ")\n";
  return 5;
}
