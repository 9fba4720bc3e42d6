// harvest-launch against stand-in processes over real LCM: restart policy,
// clean stop with nothing left behind, invalid sets, lost heartbeats,
// --exit-with and recording.
#include <gtest/gtest.h>
#include <signal.h>

#include <atomic>
#include <fstream>
#include <harvest/config_snapshot_t.hpp>
#include <harvest/process_status_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <regex>
#include <sstream>
#include <thread>

#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace harvest {
namespace {

using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::eventually;

const std::string kFixtures = testing::source_path("tests/integration/tools/fixtures");

bool alive(pid_t pid) {  // running and not a zombie
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  if (!(stat >> pid_s >> comm >> state)) return false;
  return state != "Z";
}

std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int count_lines(const std::string& text, const std::string& needle) {
  int n = 0;
  for (std::size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1)) ++n;
  return n;
}

struct Launch {
  testing::TempDir dir;
  std::string url = testing::unique_lcm_url();

  std::filesystem::path write_set(const std::string& yaml) {
    const auto path = dir / "set.yaml";
    std::ofstream(path) << yaml;
    return path;
  }
  std::unique_ptr<ChildProcess> start(const std::filesystem::path& set, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{testing::bin("harvest-launch"), set.string(), "--lcm-url", url};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<ChildProcess>(
        argv, dir / "launch.out",
        std::vector<std::string>{"PID_DIR=" + dir.path().string(), "COUNT_FILE=" + (dir / "count").string()});
  }
};

TEST(Launch, RestartsACrashingProcessPerPolicyThenStopsTheSetWhenCritical) {
  Launch l;
  const auto set = l.write_set(
      "processes:\n"
      "  - name: crash\n    command: " +
      kFixtures +
      "/crash.sh\n"
      "    harvest_options: false\n    critical: true\n"
      "    restart: {policy: on-failure, max_restarts: 2, backoff_s: 0.05}\n"
      "  - name: other\n    command: " +
      kFixtures +
      "/sleeper.sh\n    args: [other]\n"
      "    harvest_options: false\n");
  auto launch = l.start(set);
  const int rc = launch->wait(20s);
  const std::string out = launch->output();
  EXPECT_EQ(rc, 1) << out;  // a critical process that gave up fails the set
  EXPECT_EQ(count_lines(read_file(l.dir / "count"), "start"), 3) << out;  // first run + 2 restarts
  EXPECT_EQ(count_lines(out, "[crash] crashing"), 3) << out;              // output is prefixed and collected
  EXPECT_NE(out.find("restarting crash in 0.1 s (restart 2 of 2)"), std::string::npos) << out;  // back-off doubled
  EXPECT_NE(out.find("critical process crash failed"), std::string::npos) << out;
  EXPECT_NE(out.find("other stopped"), std::string::npos) << out;
  // Said once, by the console: the supervisor's health (the same news) is not logged again.
  EXPECT_EQ(count_lines(out, "crash failed"), 1) << out;
  EXPECT_EQ(out.find("[supervisor]"), std::string::npos) << out;
}

// A process marked ends_set (the simulator) ends the set when it exits, as
// --exit-with does for the demo: a set started by hand does not go on without
// its world. Without the mark the others keep running.
TEST(Launch, AProcessThatEndsTheSetStopsItWhenItExits) {
  const std::string sleeper = kFixtures + "/sleeper.sh";
  const auto set_with = [&](Launch& l, bool ends) {
    return l.write_set(
        std::string("processes:\n  - {name: world, command: ") + STANDIN_EXE +
        ", args: [--no-netcheck, --set, exit_after_s=1.0, --set, exit_code=0], ends_set: " + (ends ? "true" : "false") +
        "}\n  - {name: other, command: " + sleeper + ", args: [other], harvest_options: false}\n");
  };
  Launch ends;
  auto launch = ends.start(set_with(ends, true));
  EXPECT_EQ(launch->wait(20s), 0) << launch->output();
  const std::string out = launch->output();
  EXPECT_NE(out.find("stopping the set: world exited (ends_set)"), std::string::npos) << out;
  EXPECT_NE(out.find("other stopped"), std::string::npos) << out;

  Launch goes_on;
  auto kept = goes_on.start(set_with(goes_on, false));
  ASSERT_TRUE(eventually([&] { return kept->output().find("world exited with code 0") != std::string::npos; }, 20s))
      << kept->output();
  std::this_thread::sleep_for(1s);
  EXPECT_TRUE(kept->running()) << kept->output();
  EXPECT_EQ(kept->stop(10s), 0) << kept->output();
}

TEST(Launch, StopsEverythingOnSigtermArmFirstWithNothingLeftBehind) {
  Launch l;
  const std::string sleeper = kFixtures + "/sleeper.sh";
  const auto set = l.write_set(
      "processes:\n"
      "  - {name: first, command: " +
      sleeper +
      ", args: [first], harvest_options: false}\n"
      "  - {name: stubborn, command: " +
      sleeper +
      ", args: [stubborn, stubborn],"
      " harvest_options: false, stop_timeout_s: 0.5}\n"
      "  - {name: arm, command: " +
      sleeper +
      ", args: [arm], harvest_options: false,"
      " stop_first: true}\n"
      "  - {name: last, command: " +
      sleeper +
      ", args: [last], harvest_options: false,"
      " after: [first]}\n");
  auto launch = l.start(set);
  const std::vector<std::string> names{"first", "stubborn", "arm", "last"};
  ASSERT_TRUE(eventually(
      [&] { return std::all_of(names.begin(), names.end(), [&](const std::string& n) { return exists(l.dir / n); }); },
      10s))
      << launch->output();
  std::vector<pid_t> pids;
  for (const auto& n : names) {
    std::istringstream in(read_file(l.dir / n));
    pid_t a = 0, b = 0;
    in >> a >> b;
    pids.insert(pids.end(), {a, b});
  }
  for (pid_t p : pids) EXPECT_TRUE(alive(p)) << p;

  // Budget: 0.5 s for the stubborn one, the others stop at once.
  EXPECT_EQ(launch->stop(10s), 0) << launch->output();
  const std::string out = launch->output();
  for (pid_t p : pids) EXPECT_FALSE(alive(p)) << "left behind: " << p << "\n" << out;
  // The arm first, then the rest in reverse start order.
  const auto arm = out.find("arm stopped"), last = out.find("last stopped"), stub = out.find("stubborn stopped"),
             first = out.find("first stopped");
  ASSERT_NE(first, std::string::npos) << out;
  EXPECT_LT(arm, last) << out;
  EXPECT_LT(last, stub) << out;
  EXPECT_LT(stub, first) << out;
  EXPECT_NE(out.find("stubborn did not stop within 0.5 s: SIGKILL"), std::string::npos) << out;
}

TEST(Launch, LeavesNothingBehindWhenTheLauncherIsKilledWithSigkill) {
  Launch l;
  const std::string sleeper = kFixtures + "/sleeper.sh";
  // "careless" dies of SIGTERM and leaves its own child; "stubborn" ignores
  // SIGTERM. PR_SET_PDEATHSIG alone would leave both families running.
  const auto set = l.write_set(
      "processes:\n"
      "  - name: careless\n    command: /bin/sh\n    harvest_options: false\n"
      "    args: [-c, 'sleep 300 & echo $$ $! > $PID_DIR/careless.tmp && mv $PID_DIR/careless.tmp $PID_DIR/careless; "
      "wait']\n"
      "  - {name: stubborn, command: " +
      sleeper + ", args: [stubborn, stubborn], harvest_options: false, stop_timeout_s: 0.5}\n");
  auto launch = l.start(set);
  const std::vector<std::string> names{"careless", "stubborn"};
  ASSERT_TRUE(eventually(
      [&] { return std::all_of(names.begin(), names.end(), [&](const std::string& n) { return exists(l.dir / n); }); },
      10s))
      << launch->output();
  std::vector<pid_t> pids;
  for (const auto& n : names) {
    std::istringstream in(read_file(l.dir / n));
    pid_t a = 0, b = 0;
    in >> a >> b;
    pids.insert(pids.end(), {a, b});
  }
  for (pid_t p : pids) ASSERT_TRUE(alive(p)) << p;

  launch->signal(SIGKILL);
  EXPECT_EQ(launch->wait(5s), 128 + SIGKILL);
  // The stubborn one gets its 0.5 s, then SIGKILL.
  EXPECT_TRUE(eventually([&] { return std::none_of(pids.begin(), pids.end(), alive); }, 10s))
      << "left behind after kill -9 of the launcher:" << [&] {
           std::string left;
           for (pid_t p : pids)
             if (alive(p)) left += " " + std::to_string(p);
           return left;
         }() << "\n"
      << launch->output();
  EXPECT_NE(launch->output().find("guardian: the launcher died"), std::string::npos) << launch->output();
}

TEST(Launch, RefusesAnInvalidSetWithAClearMessage) {
  Launch l;
  const auto bad = l.write_set("processes:\n  - {name: a, command: x, after: [b]}\n");
  ChildProcess check({testing::bin("harvest-launch"), bad.string(), "--check"}, l.dir / "check.out");
  EXPECT_EQ(check.wait(10s), 2);
  EXPECT_NE(check.output().find("invalid set: " + bad.string() + ": processes.a.after: unknown process 'b'"),
            std::string::npos)
      << check.output();

  const auto missing = l.write_set("processes:\n  - {name: cam, command: harvest-no-such-process}\n");
  ChildProcess start({testing::bin("harvest-launch"), missing.string()}, l.dir / "start.out");
  EXPECT_EQ(start.wait(10s), 1);
  EXPECT_NE(start.output().find("cam: executable 'harvest-no-such-process' not found"), std::string::npos)
      << start.output();
  EXPECT_NE(start.output().find("cannot start"), std::string::npos);
}

TEST(Launch, ReportsAProcessWhoseHeartbeatStops) {
  Launch l;
  const auto set = l.write_set("processes:\n  - {name: beater, command: " STANDIN_EXE
                               ", args: [--no-netcheck], heartbeat_timeout_s: 1.5}\n");
  // Watch the launcher's own status on LCM.
  lcm::LCM lcm(l.url);
  std::mutex mu;
  std::string launcher_message;
  int8_t launcher_state = -1;
  struct Sink {
    std::mutex* mu;
    std::string* message;
    int8_t* state;
    void on(const lcm::ReceiveBuffer*, const std::string&, const harvest::process_status_t* s) {
      if (s->instance != "launch") return;
      std::lock_guard<std::mutex> g(*mu);
      *message = s->message;
      *state = s->state;
    }
  } sink{&mu, &launcher_message, &launcher_state};
  lcm.subscribe("PROCESS_STATUS", &Sink::on, &sink);
  std::atomic<bool> done{false};
  std::thread pump([&] {
    while (!done) lcm.handleTimeout(50);
  });

  auto launch = l.start(set);
  std::smatch m;
  std::string out;
  ASSERT_TRUE(eventually(
      [&] {
        out = launch->output();
        return std::regex_search(out, m, std::regex("started beater \\(pid (\\d+)\\)"));
      },
      10s))
      << out;
  const pid_t beater = std::stoi(m[1]);
  // Its log lines name it once, in front (not "[beater] 12:00:00.000 info [beater] started").
  ASSERT_TRUE(eventually([&] { return launch->output().find(" started (") != std::string::npos; }, 10s))
      << launch->output();
  EXPECT_TRUE(std::regex_search(launch->output(), std::regex(R"(\[beater\] \d\d:\d\d:\d\d\.\d{3} info started \()")))
      << launch->output();
  EXPECT_EQ(launch->output().find("info [beater]"), std::string::npos) << launch->output();
  ASSERT_TRUE(eventually(
      [&] {
        std::lock_guard<std::mutex> g(mu);
        return launcher_state == harvest::process_status_t::STATE_OK;
      },
      10s))
      << launch->output();

  kill(beater, SIGSTOP);  // alive but silent: a hung process
  EXPECT_TRUE(eventually([&] { return launch->output().find("beater: heartbeat lost") != std::string::npos; }, 10s))
      << launch->output();
  EXPECT_TRUE(eventually(
      [&] {
        std::lock_guard<std::mutex> g(mu);
        return launcher_state == harvest::process_status_t::STATE_DEGRADED &&
               launcher_message.find("beater heartbeat lost") != std::string::npos;
      },
      10s));
  kill(beater, SIGCONT);
  EXPECT_TRUE(eventually([&] { return launch->output().find("beater: heartbeat back") != std::string::npos; }, 10s))
      << launch->output();
  EXPECT_EQ(launch->stop(10s), 0);
  done = true;
  pump.join();
}

TEST(Launch, ExitsWithANamedProcessAndRecordsTheRun) {
  Launch l;
  const auto set = l.write_set(std::string("processes:\n  - {name: job, command: ") + STANDIN_EXE +
                               ", args: [--no-netcheck, --set, exit_after_s=1.5, --set, exit_code=5]}\n"
                               "recording: {enabled: true, folder: rec, file_prefix: run}\n");
  auto launch = l.start(set, {"--exit-with", "job"});
  EXPECT_EQ(launch->wait(20s), 5) << launch->output();
  std::vector<std::filesystem::path> logs;
  for (const auto& e : std::filesystem::directory_iterator(l.dir / "rec")) logs.push_back(e.path());
  ASSERT_EQ(logs.size(), 1u) << launch->output();
  EXPECT_EQ(logs[0].filename().string().rfind("run-", 0), 0u);
  bool config_seen = false, status_seen = false;
  for (const auto& r : rt::read_log(logs[0].string())) {
    if (r.channel == "CONFIG") {
      const auto c = rt::decode<harvest::config_snapshot_t>(r.data);
      config_seen = config_seen || (c && c->instance == "job");
    }
    status_seen = status_seen || r.channel == "PROCESS_STATUS";
  }
  EXPECT_TRUE(config_seen);  // the recorder was up before the process started
  EXPECT_TRUE(status_seen);
  // harvest-record (the default logger), found beside the launcher, told where it records.
  EXPECT_NE(launch->output().find("[recorder] recording to " + (l.dir / "rec").string() + "/run-"), std::string::npos)
      << launch->output();
}

TEST(Launch, GroupStartsOnlyItsProcessesAndCheckStartsNothing) {
  Launch l;
  const std::string sleeper = kFixtures + "/sleeper.sh";
  const auto set = l.write_set(
      "processes:\n"
      "  - {name: cam, command: " +
      sleeper +
      ", args: [cam], harvest_options: false,"
      " group: vision}\n"
      "  - {name: link, command: " +
      sleeper +
      ", args: [link], harvest_options: false,"
      " group: robot}\n");
  ChildProcess check({testing::bin("harvest-launch"), set.string(), "--check", "--group", "robot"},
                     l.dir / "check.out");
  EXPECT_EQ(check.wait(10s), 0) << check.output();
  EXPECT_NE(check.output().find("is valid"), std::string::npos) << check.output();
  EXPECT_NE(check.output().find("link"), std::string::npos) << check.output();
  EXPECT_FALSE(exists(l.dir / "link"));  // --check started nothing

  auto launch = l.start(set, {"--group", "robot"});
  ASSERT_TRUE(eventually([&] { return exists(l.dir / "link"); }, 10s)) << launch->output();
  EXPECT_EQ(launch->stop(10s), 0) << launch->output();
  EXPECT_FALSE(exists(l.dir / "cam")) << launch->output();
  EXPECT_EQ(launch->output().find("started cam"), std::string::npos) << launch->output();

  ChildProcess none({testing::bin("harvest-launch"), set.string(), "--group", "nope"}, l.dir / "none.out");
  EXPECT_EQ(none.wait(10s), 2);
  EXPECT_NE(none.output().find("no process in group 'nope'"), std::string::npos) << none.output();
}

// The shipped field sets, checked on a machine without the robot's hardware
// (this one: no CAN interface, no cameras, no end-effector serial adapter):
// --check names each missing device on its own line and fails; with the
// devices pointed at what exists, the same sets are valid.
TEST(Launch, CheckNamesEachMissingFieldDevice) {
  testing::TempDir dir;
  const std::string bin_dir = std::filesystem::path(testing::bin("harvest-launch")).parent_path().string();
  const auto check = [&](const std::string& set, std::vector<std::string> extra, const std::string& out) {
    std::vector<std::string> argv{testing::bin("harvest-launch"), testing::source_path("config/sets/" + set),
                                  "--check", "--bin-dir", bin_dir};
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto child = std::make_unique<ChildProcess>(argv, dir / out);
    return child;
  };
  auto robot = check("field-robot.yaml", {}, "robot.out");
  EXPECT_EQ(robot->wait(20s), 1) << robot->output();
  const std::string r = robot->output();
  const bool has_can0 = std::filesystem::exists("/sys/class/net/can0");
  if (!has_can0) {
    EXPECT_NE(r.find("harvest-launch: robot-link: site can_bus = socketcan:can0: CAN interface can0 does not exist "
                     "on this machine"),
              std::string::npos)
        << r;
  }
  EXPECT_NE(r.find("harvest-launch: ee-bridge: site ee_serial = /dev/harvest/ee-serial: /dev/harvest/ee-serial does "
                   "not exist: serial adapter unplugged"),
            std::string::npos)
      << r;
  EXPECT_NE(r.find(has_can0 ? "cannot start (" : "cannot start (2 problems)"), std::string::npos) << r;
  EXPECT_NE(r.find("bus=socketcan:can0"), std::string::npos) << r;  // the plan shows the substituted line

  auto vision = check("field-vision.yaml", {}, "vision.out");
  EXPECT_EQ(vision->wait(20s), 1) << vision->output();
  const std::string v = vision->output();
  for (const std::string camera : {"fixed", "hand"})
    EXPECT_NE(v.find("harvest-launch: camera-" + camera + ": site camera_" + camera + " = /dev/harvest/camera-" +
                     camera + ": /dev/harvest/camera-" + camera + " does not exist: camera unplugged"),
              std::string::npos)
        << v;
  EXPECT_NE(v.find("cannot start (2 problems)"), std::string::npos) << v;

  // Pointed at devices this machine has: valid. --set site.KEY for one value,
  // --site FILE for another robot's site file.
  auto robot_ok = check("field-robot.yaml",
                        {"--set", "site.can_bus=udp_multicast:239.74.163.2:43113?ttl=0", "--set",
                         "site.ee_serial=/dev/null"},
                        "robot_ok.out");
  EXPECT_EQ(robot_ok->wait(20s), 0) << robot_ok->output();
  EXPECT_NE(robot_ok->output().find("set 'field-robot' is valid"), std::string::npos) << robot_ok->output();
  std::ofstream(dir / "robot-2.yaml") << "camera_fixed: /dev/null\ncamera_hand: /dev/zero\n";
  auto vision_ok = check("field-vision.yaml", {"--site", (dir / "robot-2.yaml").string()}, "vision_ok.out");
  EXPECT_EQ(vision_ok->wait(20s), 0) << vision_ok->output();
  EXPECT_NE(vision_ok->output().find("device.path=/dev/zero"), std::string::npos) << vision_ok->output();
}

}  // namespace
}  // namespace harvest
