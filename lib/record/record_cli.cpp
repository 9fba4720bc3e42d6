#include "record/record_cli.hpp"

#include <signal.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <lcm/lcm-cpp.hpp>

#include "record/recorder.hpp"

namespace harvest::record {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void harvest_record_on_signal(int) { g_stop = true; }

struct Sink {
  Recorder* recorder;
  std::string error;  // the first write that failed; recording ends
};

void on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Sink* sink) {
  if (!sink->error.empty()) return;
  try {
    sink->recorder->on_message(channel, rbuf->recv_utime, rbuf->data, rbuf->data_size);
  } catch (const std::exception& e) {
    sink->error = e.what();
  }
}
}  // namespace

int record_main(int argc, char** argv) {
  CLI::App app(
      "Record an LCM network to a log file, as lcm-logger does, with reduced-rate channels, size "
      "splitting and size/rate/free-space reports (docs/recording-and-replay.md)",
      "harvest-record");
  RecorderOptions o;
  MeterOptions m;
  std::string file, url;
  std::vector<std::string> rates;
  double status_s = 10;
  app.add_option("file", file, "log file (with -i: FILE.00, FILE.01, ...)")->required();
  app.add_option("-c,--channel", o.channels, "channels to record, a regular expression")->capture_default_str();
  app.add_flag("-v,--invert-channels", o.invert_channels, "record the channels that do NOT match");
  app.add_option("-l,--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_flag("-i,--increment", o.increment, "never overwrite: write FILE.00, FILE.01, ...");
  app.add_option("--split-mb", o.split_mb, "start a new part every N MB (needs -i)")->check(CLI::NonNegativeNumber);
  app.add_option("--max-rate", rates,
                 "CHANNEL_REGEX=HZ: keep at most HZ messages a second of each matching channel, e.g. CAMERA_.*=5 "
                 "(repeatable; the first match applies)");
  app.add_option("--status-s", status_s, "print size, rate and free disk space every S seconds (0: never)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--warn-free-mb", m.warn_free_mb, "warn while less than this is free on the log's disk")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--warn-fill-minutes", m.warn_fill_minutes,
                 "warn while the disk would fill within this many minutes at the current rate")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  try {
    app.parse(argc, argv);
    for (const auto& r : rates) o.rate_limits.push_back(parse_rate_limit(r));
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "harvest-record: --max-rate " << e.what() << "\n";
    return 2;
  }
  o.file = file;

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << "harvest-record: error: cannot open LCM" << (url.empty() ? "" : " at " + url)
              << " (try `tools/harvest netfix`)\n";
    return 1;
  }
  std::unique_ptr<Recorder> recorder;
  try {
    recorder = std::make_unique<Recorder>(o);
  } catch (const std::exception& e) {
    std::cerr << "harvest-record: error: " << e.what() << "\n";
    return 1;
  }
  const std::filesystem::path folder = std::filesystem::absolute(o.file).parent_path();
  RecordingMeter meter(m, folder);
  Sink sink{recorder.get(), {}};
  lcm.subscribeFunction(".*", &on_message, &sink);

  struct sigaction sa {};
  sa.sa_handler = harvest_record_on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  auto report = [&](bool print_status) {
    const MeterReport r = meter.update(seconds(), recorder->stats(), free_bytes(folder));
    if (print_status) std::cout << r.status << std::endl;
    if (r.warning) std::cerr << *r.warning << std::endl;
  };
  std::cout << "recording to " << recorder->stats().current.string();
  if (o.split_mb > 0) std::cout << ", a new part every " << o.split_mb << " MB";
  std::cout << std::endl;
  for (const auto& r : o.rate_limits)
    std::cout << "channels " << r.pattern << " kept at most " << r.max_hz << " per second" << std::endl;
  report(false);  // a disk already short of space is said before anything is recorded
  double last_flush = 0, last_status = 0, last_check = 0;
  while (!g_stop && sink.error.empty()) {
    if (lcm.handleTimeout(100) < 0) {
      if (g_stop || errno == EINTR) continue;  // the stop signal interrupted the wait
      sink.error = std::string("LCM receive failed: ") + std::strerror(errno);
      break;
    }
    const double t = seconds();
    try {
      if (t - last_flush >= 1.0) {  // a crash loses at most a second; the sizes shown are on disk
        recorder->flush();
        last_flush = t;
      }
    } catch (const std::exception& e) {
      sink.error = e.what();
    }
    if (t - last_check >= 1.0) {  // once a second: warnings come as soon as they are due
      const bool print = status_s > 0 && t - last_status >= status_s;
      report(print);
      last_check = t;
      if (print) last_status = t;
    }
  }
  try {
    recorder->flush();
  } catch (const std::exception& e) {
    if (sink.error.empty()) sink.error = e.what();
  }
  const RecorderStats& s = recorder->stats();
  std::cout << "recorded " << human_bytes(static_cast<double>(s.bytes)) << ", " << s.messages << " messages in "
            << s.parts << (s.parts == 1 ? " file" : " files") << " (last " << s.current.string() << ")"
            << (s.rate_dropped > 0 ? ", " + std::to_string(s.rate_dropped) + " left out by rate limits" : "")
            << std::endl;
  if (!sink.error.empty()) {
    std::cerr << "harvest-record: error: " << sink.error << "; recording stopped\n";
    return 1;
  }
  return 0;
}

}  // namespace harvest::record
