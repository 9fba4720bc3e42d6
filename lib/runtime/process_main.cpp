#include "runtime/process_main.hpp"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdlib>
#include <iostream>

#include "runtime/allocator.hpp"
#include "runtime/heartbeat.hpp"
#include "runtime/live_runner.hpp"
#include "runtime/netcheck.hpp"

#ifndef HARVEST_VERSION
#define HARVEST_VERSION "unknown"
#endif

namespace harvest::rt {

namespace {
LiveRunner* g_runner = nullptr;

extern "C" void on_signal(int) {
  if (g_runner != nullptr) g_runner->request_stop(0);
}

std::string hostname() {
  char buf[256] = {};
  gethostname(buf, sizeof buf - 1);
  return buf;
}
}  // namespace

std::string software_version() { return HARVEST_VERSION; }

config::Document load_config(const std::string& path, const std::vector<std::string>& overrides) {
  config::Document doc = path.empty() ? config::Document::load_string("{}", "<defaults>")
                                      : config::Document::load_file(path);
  for (const auto& o : overrides) doc.apply_override(o);
  return doc;
}

int run_process(int argc, char** argv, const std::string& process, const NodeFactory& make,
                const ProcessOptions& options) {
  CLI::App app(options.description.empty() ? process : options.description, process);
  std::string config_path, lcm_url, prefix, instance, log_level = "info";
  std::vector<std::string> overrides;
  bool check_config = false, no_netcheck = false;
  app.add_option("--config,-c", config_path, "YAML configuration file");
  app.add_option("--set", overrides, "override a configuration value, KEY.PATH=VALUE (repeatable)");
  app.add_option("--lcm-url", lcm_url, "LCM provider URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_option("--prefix", prefix, "channel prefix, so two arms can share one network");
  app.add_option("--instance", instance, "instance name for heartbeats and logs");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.add_flag("--check-config", check_config, "validate the configuration, print it and exit");
  app.add_flag("--no-netcheck", no_netcheck, "skip the network self-check");
  bool no_journal = false;
  app.add_flag("--no-journal", no_journal,
               "publish no JOURNAL of what the nodes handled (without it a recording replays approximately: "
               "docs/replay.md)");
  if (options.add_options) options.add_options(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  if (instance.empty()) instance = process;

  auto logger = spdlog::stderr_color_mt(instance);
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ [%n] %v");
  spdlog::set_level(spdlog::level::from_str(log_level));

  ProcessEnv env{process, instance, lcm_url, prefix};
  NodeList nodes;
  std::string effective;
  try {
    config::Document doc = load_config(config_path, overrides);
    nodes = make(doc.root(), env);
    doc.check_unused();
    effective = doc.emit();
  } catch (const config::Error& e) {
    spdlog::error("configuration error: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("cannot start: {}", e.what());
    return 1;
  }
  if (check_config) {
    std::cout << effective;
    return 0;
  }

  if (!no_netcheck) {
    for (const auto& f : check_network())
      if (!f.ok) spdlog::warn("network: {}; fix: {}", f.what, f.fix);
  }

  if (!keep_freed_memory()) spdlog::warn("the allocator refused its settings: large blocks are unmapped when freed");
  try {
    LiveOptions live;
    live.lcm_url = lcm_url;
    live.prefix = prefix;
    if (!no_journal) live.journal_instance = instance;
    LiveRunner runner(live);
    std::string cmdline;
    for (int i = 0; i < argc; ++i) cmdline += (i ? " " : "") + std::string(argv[i]);
    std::vector<const Node*> watched;
    for (auto& n : nodes) watched.push_back(n.get());
    HeartbeatNode heartbeat(ProcessIdentity{process, instance, hostname(), static_cast<int>(getpid()), config_path,
                                            effective, cmdline, software_version()},
                            watched);
    // The heartbeat attaches last: its CONFIG snapshot is stamped when every
    // node has subscribed, the moment from which replay feeds the node its
    // live twin surely received (docs/replay.md).
    for (auto& n : nodes) runner.add(*n);
    runner.add(heartbeat);

    g_runner = &runner;
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    std::signal(SIGPIPE, SIG_IGN);

    spdlog::info("started ({}), pid {}", software_version(), getpid());
    const int rc = runner.run();
    g_runner = nullptr;
    spdlog::info("stopped");
    return rc;
  } catch (const std::exception& e) {
    g_runner = nullptr;
    spdlog::error("fatal: {}", e.what());
    return 1;
  }
}

}  // namespace harvest::rt
