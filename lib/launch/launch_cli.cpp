#include "launch/launch_cli.hpp"

#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>

#include "launch/deputy.hpp"
#include "launch/sheriff.hpp"
#include "launch/site_check.hpp"
#include "launch/supervisor.hpp"
#include "runtime/file_stamp.hpp"
#include "runtime/heartbeat.hpp"
#include "runtime/live_runner.hpp"
#include "runtime/netcheck.hpp"
#include "runtime/process_main.hpp"

namespace harvest::launch {

namespace {
rt::LiveRunner* g_runner = nullptr;
extern "C" void harvest_launch_on_signal(int) {
  if (g_runner != nullptr) g_runner->request_stop(0);
}

void print_plan(const SetSpec& set, const std::vector<std::size_t>& selected) {
  std::cout << "set '" << set.name << "' from " << set.file.string() << ", executables from " << set.bin_dir.string()
            << "\n";
  std::cout << "lcm url: " << (set.lcm_url.empty() ? "(LCM default)" : set.lcm_url)
            << (set.prefix.empty() ? "" : ", prefix " + set.prefix) << "\n";
  if (!set.site.file.empty() || !set.site.values.empty()) {
    std::cout << "site: " << (set.site.file.empty() ? "(command line only)" : set.site.file.string()) << "\n";
    for (const auto& [k, v] : set.site.values) std::cout << "  " << k << " = " << v << "\n";
  }
  if (set.recording.enabled) {
    std::cout << "recording:";
    for (const auto& a : recorder_command_line(set, "<time>")) std::cout << " " << a;
    std::cout << "\n";
  }
  std::cout << "start order:\n";
  int n = 1;
  for (std::size_t i : selected) {
    const ProcessSpec& p = set.processes[i];
    std::cout << "  " << n++ << ". " << p.name << " [group " << p.group << (p.critical ? ", critical" : "")
              << (p.stop_first ? ", stop first" : "") << (p.ends_set ? ", ends the set" : "") << "]";
    if (!p.after.empty()) {
      std::cout << " after";
      for (const auto& d : p.after) std::cout << " " << d;
    }
    std::cout << "\n     ";
    for (const auto& a : command_line(set, p)) std::cout << " " << a;
    std::cout << "\n";
  }
}

std::string host_name() {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  return host;
}

void install_stop_handlers(rt::LiveRunner& runner) {
  g_runner = &runner;
  struct sigaction sa {};
  sa.sa_handler = harvest_launch_on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  for (char c : text + ",") {
    if (c == ',' || c == ' ') {
      if (!item.empty()) out.push_back(item);
      item.clear();
    } else {
      item += c;
    }
  }
  return out;
}

struct SheriffArgs {
  std::string restart, stop, start, key, sender, lcm_url, prefix;
  bool list = false, no_table = false, quiet = false;
  double timeout_s = 20, list_s = 3;
};

// harvest-launch --sheriff: every deputy's table and output; or one order.
int sheriff_main(const SheriffArgs& a, const std::string& cmdline) {
  SheriffOptions o;
  try {
    int orders = 0;
    for (const auto& [target, action] :
         {std::pair{a.restart, OrderAction::kRestart}, {a.stop, OrderAction::kStop}, {a.start, OrderAction::kStart}}) {
      if (target.empty()) continue;
      ++orders;
      o.order = parse_target(target, action);
    }
    if (orders > 1 || (orders == 1 && a.list)) throw std::invalid_argument("one of --restart, --stop, --start, --list");
  } catch (const std::invalid_argument& e) {
    std::cerr << "harvest-launch --sheriff: " << e.what() << "\n";
    return 2;
  }
  o.order_timeout = static_cast<rt::Micros>(a.timeout_s * 1e6);
  if (a.list) o.list_after = static_cast<rt::Micros>(a.list_s * 1e6);
  o.print_output = !o.order && !a.list && !a.quiet;
  o.sender = a.sender;
  const char* user = std::getenv("USER");
  o.source = std::string(user ? user : "?") + "@" + host_name() + " (harvest-launch --sheriff pid " +
             std::to_string(getpid()) + ")";
  try {
    const security::Key key = security::load_named_key(a.key.empty() ? security::default_command_key() : a.key);
    Console console(std::cout, isatty(STDOUT_FILENO) && !a.no_table && !o.order && !a.list);
    Sheriff sheriff(o, console, key);
    rt::LiveRunner runner(rt::LiveOptions{a.lcm_url, a.prefix, rt::kSecond});
    rt::HeartbeatNode heartbeat(rt::ProcessIdentity{"launch", "sheriff", host_name(), static_cast<int>(getpid()), "",
                                                    "", cmdline, rt::software_version()},
                                {&sheriff});
    runner.add(heartbeat);
    runner.add(sheriff);
    install_stop_handlers(runner);
    const int rc = runner.run();
    g_runner = nullptr;
    if (a.list) {
      std::cout << render_table(sheriff.rows());
      if (sheriff.deputies() == 0) std::cerr << "harvest-launch --sheriff: no deputy seen in " << a.list_s << " s\n";
    }
    return rc;
  } catch (const std::exception& e) {
    g_runner = nullptr;
    std::cerr << "harvest-launch --sheriff: " << e.what() << "\n";
    return 2;
  }
}
}  // namespace

int launch_main(int argc, char** argv) {
  CLI::App app("Start, watch and stop a process set (docs/launcher.md)", "harvest-launch");
  std::string site_path, set_path, group, exit_with, bin_dir, instance = "launch", log_level = "info", lcm_url;
  std::vector<std::string> overrides;
  bool check = false, no_table = false, sheriff = false;
  std::string deputy, obey = "operator,console";
  SheriffArgs sh;
  app.add_option("set", set_path, "process set file (config/sets/*.yaml); not with --sheriff");
  app.add_option("--deputy", deputy,
                 "run as the deputy NAME: publish DEPUTY_STATUS and DEPUTY_OUTPUT, obey signed LAUNCH_ORDER");
  app.add_flag("--sheriff", sheriff, "show every deputy's processes and output (no set); or send one order");
  app.add_option("--restart", sh.restart, "with --sheriff: restart DEPUTY/PROCESS and wait for its new pid");
  app.add_option("--stop", sh.stop, "with --sheriff: stop DEPUTY/PROCESS (not restarted by policy)");
  app.add_option("--start", sh.start, "with --sheriff: start DEPUTY/PROCESS");
  app.add_flag("--list", sh.list, "with --sheriff: print every deputy's table after --wait seconds and exit");
  app.add_option("--wait", sh.list_s, "with --list: how long to listen [s] (default 3)");
  app.add_option("--timeout", sh.timeout_s, "with an order: give up after this long [s] (default 20)");
  app.add_flag("--quiet", sh.quiet, "with --sheriff: no forwarded output lines, only news and the table");
  app.add_option("--key", sh.key,
                 "command key: 'sim' or the robot's key file (default $HARVEST_COMMAND_KEY or sim); the sheriff signs "
                 "orders with it, a deputy obeys orders signed with it");
  app.add_option("--sender", sh.sender, "with --sheriff: the id orders are signed as (default operator)")
      ->default_val("operator");
  app.add_option("--obey", obey, "with --deputy: senders whose orders it obeys (default operator,console)");
  app.add_option("--prefix", sh.prefix, "with --sheriff: channel prefix of the deputies' sets");
  app.add_flag("--check", check, "validate the set and print what would start, start nothing");
  app.add_option("--group", group, "start only the processes of this host group");
  app.add_option("--exit-with", exit_with, "stop the set when this process exits; exit with its code");
  app.add_option("--bin-dir", bin_dir, "where harvest-* executables are (default: the set's bin_dir)");
  app.add_option("--set", overrides, "override a value of the set file, KEY.PATH=VALUE (repeatable)");
  app.add_option("--site", site_path,
                 "site file of this robot (config/site/*.yaml: CAN bus, cameras, serial port); replaces the set's");
  app.add_option("--lcm-url", lcm_url, "LCM URL (overrides the set's lcm_url)");
  app.add_option("--instance", instance, "instance name of the launcher's own PROCESS_STATUS");
  app.add_flag("--no-table", no_table, "plain output lines even on a terminal");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  std::string cmdline;
  for (int i = 0; i < argc; ++i) cmdline += (i ? " " : "") + std::string(argv[i]);
  if (sheriff) {
    if (!set_path.empty() || !deputy.empty()) {
      std::cerr << "harvest-launch: --sheriff takes no set and no --deputy\n";
      return 2;
    }
    spdlog::set_default_logger(spdlog::stderr_color_mt("sheriff"));
    spdlog::set_pattern("%H:%M:%S.%e %^%l%$ [%n] %v");
    spdlog::set_level(spdlog::level::from_str(log_level));
    sh.lcm_url = lcm_url;
    sh.no_table = no_table;
    return sheriff_main(sh, cmdline);
  }
  if (set_path.empty()) {
    std::cerr << "harvest-launch: a set file is required (or --sheriff)\n";
    return 2;
  }
  if (!sh.restart.empty() || !sh.stop.empty() || !sh.start.empty() || sh.list) {
    std::cerr << "harvest-launch: --restart, --stop, --start and --list go with --sheriff\n";
    return 2;
  }
  if (!deputy.empty() && instance == "launch") instance = "launch-" + deputy;
  spdlog::set_default_logger(spdlog::stderr_color_mt(instance));
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ [%n] %v");
  spdlog::set_level(spdlog::level::from_str(log_level));

  SetSpec set;
  std::string effective;
  try {
    std::vector<std::string> set_overrides;
    SiteOverrides site;
    site.file = site_path;
    split_site_overrides(overrides, set_overrides, site);
    config::Document doc = rt::load_config(set_path, set_overrides);
    set = parse_set(doc.root(), set_path, bin_dir, site);
    effective = doc.emit();
  } catch (const config::Error& e) {
    std::cerr << "harvest-launch: invalid set: " << e.what() << "\n";
    return 2;
  }
  if (!lcm_url.empty()) set.lcm_url = lcm_url;
  const std::vector<std::size_t> selected = select_group(set, group);
  if (selected.empty()) {
    std::cerr << "harvest-launch: no process in group '" << group << "'\n";
    return 2;
  }
  if (!exit_with.empty() && std::none_of(selected.begin(), selected.end(),
                                         [&](std::size_t i) { return set.processes[i].name == exit_with; })) {
    std::cerr << "harvest-launch: --exit-with " << exit_with << ": no such process in the started set\n";
    return 2;
  }
  auto problems = preflight(set, selected);
  for (auto& p : check_site(set, selected)) problems.push_back(std::move(p));
  if (check) {
    print_plan(set, selected);
    for (const auto& f : rt::check_network())
      if (!f.ok) std::cerr << "harvest-launch: warning: network: " << f.what << "; fix: " << f.fix << "\n";
  }
  for (const auto& p : problems) std::cerr << "harvest-launch: " << p << "\n";
  if (!problems.empty()) {
    std::cerr << "harvest-launch: set '" << set.name << "' cannot start (" << problems.size() << " problem"
              << (problems.size() > 1 ? "s" : "") << ")\n";
    return 1;
  }
  if (check) {
    std::cout << "set '" << set.name << "' is valid\n";
    return 0;
  }

  if (set.recording.enabled) {
    std::error_code ec;
    std::filesystem::create_directories(set.recording.folder, ec);
    if (ec) {
      std::cerr << "harvest-launch: cannot create recording folder " << set.recording.folder.string() << ": "
                << ec.message() << "\n";
      return 1;
    }
  }
  try {
    Console console(std::cout, isatty(STDOUT_FILENO) && !no_table);
    SupervisorOptions sopts;
    sopts.group = group;
    sopts.exit_with = exit_with;
    sopts.own_instance = instance;
    // A deputy's key is loaded before anything starts: a bad key file starts nothing.
    std::optional<security::Key> deputy_key;
    if (!deputy.empty()) {
      deputy_key = security::load_named_key(sh.key.empty() ? security::default_command_key() : sh.key);
      for (std::size_t i : selected)
        for (const auto& arg : command_line(set, set.processes[i]))
          if (const auto at = arg.find("socketcan:"); at != std::string::npos)
            security::refuse_sim_key_on_real_bus(*deputy_key, arg.substr(at), "harvest-launch --deputy key");
    }
    Supervisor supervisor(set, sopts, console, rt::utc_file_stamp());
    rt::LiveRunner runner(rt::LiveOptions{set.lcm_url, set.prefix, supervisor.shutdown_budget()});
    const std::string host = host_name();
    std::vector<const rt::Node*> watched{&supervisor};
    std::unique_ptr<Deputy> deputy_node;
    if (deputy_key) {
      DeputyOptions d;
      d.name = deputy;
      d.host = host;
      d.pid = static_cast<int>(getpid());
      d.set_name = set.name;
      d.groups = group;
      d.authority.key = sh.key.empty() ? security::default_command_key() : sh.key;
      d.authority.operators = split_list(obey);
      deputy_node = std::make_unique<Deputy>(supervisor, d, *deputy_key);
      watched.push_back(deputy_node.get());
    }
    rt::HeartbeatNode heartbeat(rt::ProcessIdentity{"launch", instance, host, static_cast<int>(getpid()), set_path,
                                                    effective, cmdline, rt::software_version()},
                                watched);
    runner.add(heartbeat);
    if (deputy_node) runner.add(*deputy_node);  // attached first: it hears the supervisor's first news
    runner.add(supervisor);
    install_stop_handlers(runner);
    const int rc = runner.run();
    g_runner = nullptr;
    console.line("launch", "all stopped, exit code " + std::to_string(rc));
    return rc;
  } catch (const std::exception& e) {
    g_runner = nullptr;
    std::cerr << "harvest-launch: fatal: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace harvest::launch
