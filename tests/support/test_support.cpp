#include "test_support.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#ifndef HARVEST_SOURCE_DIR
#define HARVEST_SOURCE_DIR "."
#endif
#ifndef HARVEST_TEST_BIN_DIR
#define HARVEST_TEST_BIN_DIR "build/tests"
#endif
#ifndef HARVEST_BIN_DIR
#define HARVEST_BIN_DIR "build/bin"
#endif

namespace harvest::testing {

namespace {
// Nobody on this host has a UDP socket on the port now. LCM shares its port
// with SO_REUSEADDR, but a test's virtual CAN bus or another tool bound
// without it makes LCM's bind fail ("bind: Address already in use") and the
// test hear nothing.
bool udp_port_free(int port) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return true;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  a.sin_port = htons(static_cast<uint16_t>(port));
  const bool ok = bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
  close(fd);
  return ok;
}
}  // namespace

std::string unique_lcm_url() {
  static std::atomic<int> counter{0};
  int port = 0;
  for (int tries = 0; tries < 100; ++tries) {
    port = 20000 + static_cast<int>((getpid() * 7 + counter++ * 13) % 40000);
    if (udp_port_free(port)) break;
  }
  return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
}

std::string unique_can_bus() {
  static std::atomic<int> counter{0};
  const int pid = static_cast<int>(getpid());
  int n = 0, port = 0;
  for (int tries = 0; tries < 100; ++tries) {
    n = counter++;
    // Above the ports unique_lcm_url() hands out (20000-59999): a test's LCM
    // port and its bus port may never coincide (the simulator refuses a bus
    // port another socket holds).
    port = 61000 + (pid * 7 + n * 13) % 4000;
    if (udp_port_free(port)) break;
  }
  return "udp_multicast:239.74.166." + std::to_string(10 + (pid + n) % 200) + ":" + std::to_string(port) + "?ttl=0";
}

TempDir::TempDir() {
  std::string templ = (std::filesystem::temp_directory_path() / "harvest-test-XXXXXX").string();
  if (mkdtemp(templ.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = templ;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

ChildProcess::ChildProcess(const std::vector<std::string>& argv, const std::filesystem::path& output_file,
                           const std::vector<std::string>& extra_env)
    : output_file_(output_file) {
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    // A test that aborts (a failed ASSERT in a helper thread, a sanitizer
    // report) skips the destructor that stops its children: they get SIGTERM
    // from the kernel instead of running on and loading the machine.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);
    const int fd = open(output_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    for (const auto& e : extra_env) putenv(const_cast<char*>(e.c_str()));
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
}

ChildProcess::~ChildProcess() {
  if (!exited_) stop();
}

bool ChildProcess::running() {
  if (exited_) return false;
  int st = 0;
  const pid_t r = waitpid(pid_, &st, WNOHANG);
  if (r == pid_) {
    exited_ = true;
    status_ = st;
    return false;
  }
  return true;
}

static int decode_status(int st) {
  if (WIFEXITED(st)) return WEXITSTATUS(st);
  if (WIFSIGNALED(st)) return 128 + WTERMSIG(st);
  return -1;
}

int ChildProcess::wait(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (running()) {
    if (std::chrono::steady_clock::now() >= end) return -1;
    usleep(5000);
  }
  return decode_status(status_);
}

void ChildProcess::signal(int sig) {
  if (!exited_) kill(pid_, sig);
}

int ChildProcess::stop(std::chrono::milliseconds timeout, int sig) {
  if (exited_) return decode_status(status_);
  kill(pid_, sig);
  int rc = wait(timeout);
  if (rc == -1) {
    kill(pid_, SIGKILL);
    rc = wait(std::chrono::seconds(5));
  }
  return rc;
}

std::string ChildProcess::output() const {
  std::ifstream f(output_file_);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string bin(const std::string& name) { return std::string(HARVEST_BIN_DIR) + "/" + name; }
std::string bin_dir() { return HARVEST_BIN_DIR; }

std::vector<std::string> realtime(std::vector<std::string> argv, int priority) {
  static const bool allowed = std::system("chrt -f 1 true >/dev/null 2>&1") == 0;
  if (allowed) argv.insert(argv.begin(), {"chrt", "-f", std::to_string(priority)});
  return argv;
}
std::string test_bin(const std::string& name) { return std::string(HARVEST_TEST_BIN_DIR) + "/" + name; }
std::string source_path(const std::string& relative) { return std::string(HARVEST_SOURCE_DIR) + "/" + relative; }

}  // namespace harvest::testing
