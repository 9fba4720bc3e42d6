// Helpers for tests: isolated LCM URLs, temporary folders, child processes.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

namespace harvest::testing {

// A multicast URL no other test uses at the same time (ctest runs tests in
// parallel): a port derived from the pid and a counter, TTL 0 (this host only).
std::string unique_lcm_url();
// A virtual CAN bus (udp_multicast, docs/can.md) no other test uses at the
// same time: group and port from the pid and a counter, TTL 0.
std::string unique_can_bus();

// A fresh empty folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// A process started by a test and stopped by it, by PID. Output (stdout and
// stderr) goes to a file so a failing test can show it.
class ChildProcess {
 public:
  ChildProcess(const std::vector<std::string>& argv, const std::filesystem::path& output_file,
               const std::vector<std::string>& extra_env = {});
  ~ChildProcess();  // SIGTERM, then SIGKILL after 5 s
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool running();
  // SIGTERM (or `sig`), wait up to `timeout`, then SIGKILL. Returns the exit
  // code (128+signal if killed by a signal).
  int stop(std::chrono::milliseconds timeout = std::chrono::seconds(5), int sig = 15);
  // Wait for the process to exit by itself; -1 on timeout.
  int wait(std::chrono::milliseconds timeout);
  void signal(int sig);
  std::string output() const;

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  bool exited_ = false;
  std::filesystem::path output_file_;
};

// `argv` run at SCHED_FIFO `priority` through chrt when this machine allows
// it (root or CAP_SYS_NICE), else unchanged: a stand-in for hardware with a
// processor of its own (the simulated drives) then keeps its deadlines beside
// the real-time robot link, as the hardware does.
std::vector<std::string> realtime(std::vector<std::string> argv, int priority);

// Path of a built executable in build/bin.
std::string bin(const std::string& name);
// The folder of the harvest-* executables (build/bin).
std::string bin_dir();
// Path of a test-only executable in build/tests.
std::string test_bin(const std::string& name);
// Path inside the source tree.
std::string source_path(const std::string& relative);

// Poll `pred` every 10 ms until it is true or `timeout` passes.
template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    struct timespec ts {0, 10'000'000};
    nanosleep(&ts, nullptr);
  }
  return pred();
}

}  // namespace harvest::testing
