#include "launch/guardian.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <system_error>

namespace harvest::launch {

namespace {

struct Record {
  int32_t group;
  int32_t signal;  // 0: forget the group
};

constexpr int kMaxGroups = 1024;

void sleep_ms(long ms) {
  timespec ts{ms / 1000, (ms % 1000) * 1'000'000};
  while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
  }
}

int64_t monotonic_ms() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000 + ts.tv_nsec / 1'000'000;
}

// The guardian process. Between fork and _exit only async-signal-safe calls:
// the launcher may have had threads.
[[noreturn]] void guard(int fd, int64_t grace_ms) {
  Record groups[kMaxGroups];
  int n = 0;
  alignas(Record) unsigned char buf[sizeof(Record) * 64];
  std::size_t have = 0;
  for (;;) {
    const ssize_t r = read(fd, buf + have, sizeof buf - have);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;  // end of file (or error): the launcher is gone
    have += static_cast<std::size_t>(r);
    std::size_t used = 0;
    for (; used + sizeof(Record) <= have; used += sizeof(Record)) {
      Record rec;
      std::memcpy(&rec, buf + used, sizeof rec);
      if (rec.group <= 1) continue;
      int i = 0;
      while (i < n && groups[i].group != rec.group) ++i;
      if (rec.signal == 0) {
        if (i < n) groups[i] = groups[--n];
      } else if (i < n) {
        groups[i].signal = rec.signal;
      } else if (n < kMaxGroups) {
        groups[n++] = rec;
      }
    }
    std::memmove(buf, buf + used, have - used);
    have -= used;
  }
  if (n == 0) _exit(0);
  static const char msg[] = "harvest-launch guardian: the launcher died without stopping its processes: stopping them\n";
  (void)!write(STDERR_FILENO, msg, sizeof msg - 1);
  for (int i = 0; i < n; ++i) {
    kill(-groups[i].group, groups[i].signal);
    kill(-groups[i].group, SIGCONT);  // a stopped process must see its signal
  }
  const int64_t deadline = monotonic_ms() + grace_ms;
  for (;;) {
    bool any = false;
    for (int i = 0; i < n && !any; ++i) any = kill(-groups[i].group, 0) == 0;
    if (!any || monotonic_ms() >= deadline) break;
    sleep_ms(20);
  }
  for (int i = 0; i < n; ++i) kill(-groups[i].group, SIGKILL);
  _exit(0);
}

}  // namespace

Guardian::Guardian(std::chrono::milliseconds grace) {
  int sv[2];
  // Close-on-exec: a child holding the launcher's end would keep the guardian
  // from ever seeing end-of-file.
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
    throw std::system_error(errno, std::generic_category(), "guardian socketpair");
  const int64_t grace_ms = grace.count();
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(sv[0]);
    close(sv[1]);
    throw std::system_error(err, std::generic_category(), "guardian fork");
  }
  if (pid == 0) {
    // Its own process group: a Ctrl-C or a signal to the launcher's group
    // must not take the guardian with it.
    setpgid(0, 0);
    signal(SIGINT, SIG_IGN);
    signal(SIGHUP, SIG_IGN);
    signal(SIGQUIT, SIG_IGN);
    signal(SIGPIPE, SIG_IGN);
    close(sv[0]);
    // Hold nothing of the launcher's but stderr: a pipe reader waiting for
    // the launcher's stdout to close must not wait for us.
    const int keep = sv[1] > STDERR_FILENO ? sv[1] : fcntl(sv[1], F_DUPFD, STDERR_FILENO + 1);
    if (keep < 0) _exit(1);
    close(STDIN_FILENO);
    close(STDOUT_FILENO);
    if (keep > 3) close_range(3, static_cast<unsigned>(keep) - 1, 0);
    close_range(static_cast<unsigned>(keep) + 1, ~0U, 0);
    const char ready = 'r';
    (void)!write(keep, &ready, 1);
    guard(keep, grace_ms);
  }
  close(sv[1]);
  setpgid(pid, pid);
  pid_ = pid;
  fd_ = sv[0];
  // Wait until its signal dispositions are set: from here on, a Ctrl-C or a
  // kill of the launcher cannot take the guardian with it.
  char ready = 0;
  while (read(fd_, &ready, 1) < 0 && errno == EINTR) {
  }
}

Guardian::~Guardian() {
  if (fd_ >= 0) close(fd_);
  if (pid_ > 0) {
    int status = 0;
    while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
}

void Guardian::send(pid_t group, int signal) {
  const Record rec{static_cast<int32_t>(group), signal};
  // MSG_NOSIGNAL: a dead guardian must not take the launcher with it (SIGPIPE).
  [[maybe_unused]] const ssize_t r = ::send(fd_, &rec, sizeof rec, MSG_NOSIGNAL);
}

void Guardian::watch(pid_t group, int stop_signal) { send(group, stop_signal > 0 ? stop_signal : SIGTERM); }

void Guardian::forget(pid_t group) { send(group, 0); }

}  // namespace harvest::launch
