// harvest-operator: sends one operator command or emergency stop to the
// servo controller from the shell (docs/servo-controller.md).
//
//   harvest-operator start|pause|resume|abort|home|reset-fault|estop|estop-clear
//                    [--source WHO] [--reason TEXT] [--lcm-url URL] [--prefix P] [--repeat N]
#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <cstdlib>
#include <iostream>
#include <thread>

#include "runtime/channels.hpp"
#include "servo/operator_command.hpp"

namespace {

std::string default_source() {
  const char* user = std::getenv("USER");
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  return std::string(user ? user : "unknown") + "@" + host + " (harvest-operator)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Send an operator command or an emergency stop to the servo controller"};
  std::string verb, source = default_source(), reason, url, prefix;
  int repeat = 0;  // 0: three copies of an emergency stop, one of anything else
  app.add_option("command", verb, "start, pause, resume, abort, home, reset-fault, estop, estop-clear")
      ->required()
      ->check(CLI::IsMember(harvest::servo::operator_verbs()));
  app.add_option("--source", source, "who sends it (default user@host)");
  app.add_option("--reason", reason, "reason, for estop");
  app.add_option("--lcm-url", url, "LCM provider URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_option("--prefix", prefix, "channel prefix of the arm's process graph");
  app.add_option("--repeat", repeat, "send this many copies 20 ms apart (default: 3 for estop verbs, else 1)")
      ->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);

  if (repeat == 0) repeat = verb.rfind("estop", 0) == 0 ? 3 : 1;

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << "harvest-operator: cannot open LCM (" << (url.empty() ? "default URL" : url) << ")\n";
    return 1;
  }
  const auto now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  const auto msg = harvest::servo::make_operator_message(verb, source, reason, now_us);
  // An emergency stop goes out more than once: UDP multicast may drop a datagram.
  for (int i = 0; i < repeat; ++i) {
    int rc = 0;
    if (const auto* e = std::get_if<harvest::emergency_stop_t>(&msg))
      rc = lcm.publish(prefix + harvest::channels::kEmergencyStop, e);
    else
      rc = lcm.publish(prefix + harvest::channels::kOperatorCommand, &std::get<harvest::operator_command_t>(msg));
    if (rc != 0) {
      std::cerr << "harvest-operator: publish failed\n";
      return 1;
    }
    if (i + 1 < repeat) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::cout << "sent " << verb << " (" << repeat << "x) as " << source << "\n";
  return 0;
}
