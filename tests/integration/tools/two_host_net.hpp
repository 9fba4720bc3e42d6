// Two hosts on one machine for the deputy tests: two network namespaces
// joined by a veth pair (docs/launcher.md "Several hosts"), and helpers.
#pragma once

#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace harvest::testing::two_hosts {

namespace fs = std::filesystem;

inline bool alive(pid_t pid) {  // running and not a zombie
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  if (!(stat >> pid_s >> comm >> state)) return false;
  return state != "Z";
}

inline std::string net_ns_of(pid_t pid) {
  std::error_code ec;
  return fs::read_symlink("/proc/" + std::to_string(pid) + "/ns/net", ec).string();
}

inline int sh(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()); }

// Two hosts: namespaces <base>a and <base>b, veth 10.77.<n>.1 <-> .2, lo up,
// multicast routed over the veth.
class TwoHostNet {
 public:
  TwoHostNet() {
    const std::string base = "hv" + std::to_string(getpid());
    a_ = base + "a";
    b_ = base + "b";
    const std::string subnet = "10.77." + std::to_string(getpid() % 250) + ".";
    if (sh("ip netns add " + a_) != 0) return;
    ok_ = sh("ip netns add " + b_) == 0 &&
          sh("ip link add v" + a_ + " netns " + a_ + " type veth peer name v" + b_ + " netns " + b_) == 0;
    for (const auto& [ns, ip] : {std::pair{a_, subnet + "1"}, std::pair{b_, subnet + "2"}}) {
      ok_ = ok_ && sh("ip -n " + ns + " link set lo up") == 0 &&
            sh("ip -n " + ns + " addr add " + ip + "/24 dev v" + ns) == 0 &&
            sh("ip -n " + ns + " link set v" + ns + " up") == 0 &&
            sh("ip -n " + ns + " route add 224.0.0.0/4 dev v" + ns) == 0;
    }
  }
  ~TwoHostNet() {
    sh("ip netns del " + a_);  // takes its end of the veth, and so the pair, with it
    sh("ip netns del " + b_);
  }
  bool ok() const { return ok_; }
  const std::string& a() const { return a_; }
  const std::string& b() const { return b_; }
  // argv run in namespace ns (ip netns exec execs it: the pid is the process's).
  std::vector<std::string> in(const std::string& ns, std::vector<std::string> argv) const {
    argv.insert(argv.begin(), {"ip", "netns", "exec", ns});
    return argv;
  }

 private:
  std::string a_, b_;
  bool ok_ = false;
};

inline std::string ttl1_url() {
  std::string url = unique_lcm_url();
  return url.replace(url.find("ttl=0"), 5, "ttl=1");
}

// The last pid the sheriff reported for host/process, -1 if none yet.
inline int reported_pid(const std::string& out, const std::string& target) {
  const std::regex re("\\[sheriff\\] " + target + " running \\(pid (\\d+)\\)");
  int pid = -1;
  for (auto it = std::sregex_iterator(out.begin(), out.end(), re); it != std::sregex_iterator(); ++it)
    pid = std::stoi((*it)[1]);
  return pid;
}

struct Ran {
  int code;
  std::string out;
};
inline Ran run(const std::vector<std::string>& argv, const fs::path& out_file, std::chrono::milliseconds timeout) {
  ChildProcess p(argv, out_file);
  const int code = p.wait(timeout);
  return {code, p.output()};
}

}  // namespace harvest::testing::two_hosts
