// Takes a process set down when the launcher dies without stopping it
// (SIGKILL, a crash, the OOM killer).
//
// PR_SET_PDEATHSIG (set on every child by spawn()) reaches only the direct
// children, and only with one signal: a child that ignores it, or a shell
// that dies of it and leaves its own children, would survive the launcher.
// The guardian is a small process forked before any child, in its own
// process group, holding one end of a socket whose other end only the
// launcher holds (close-on-exec). The launcher registers every child's
// process group as it starts it and forgets it once it has reaped it and
// killed what was left in it. When the socket reaches end-of-file (the
// kernel closes it however the launcher died) with groups still registered,
// the guardian sends each group its stop signal, waits up to `grace` for
// them to go, then SIGKILLs every group and exits. A clean stop forgets
// every group first, so the guardian then just exits.
#pragma once

#include <sys/types.h>

#include <chrono>

namespace harvest::launch {

class Guardian {
 public:
  // Forks the guardian. Throws std::system_error if it cannot.
  explicit Guardian(std::chrono::milliseconds grace);
  // Closes the socket (the guardian stops the groups still registered) and
  // waits for the guardian to exit.
  ~Guardian();
  Guardian(const Guardian&) = delete;
  Guardian& operator=(const Guardian&) = delete;

  // Stop `group` with `stop_signal` (then SIGKILL) if the launcher dies.
  void watch(pid_t group, int stop_signal);
  // The group is gone: never signal it again (its id may be reused).
  void forget(pid_t group);

  pid_t pid() const { return pid_; }

 private:
  void send(pid_t group, int signal);
  pid_t pid_ = -1;
  int fd_ = -1;
};

}  // namespace harvest::launch
