// Starting and signalling supervised child processes.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace harvest::launch {

struct Spawned {
  pid_t pid = -1;
  int output_fd = -1;  // read end of the child's stdout+stderr, non-blocking
};

// Starts argv in its own process group (so a stop reaches its own children
// too) with stdout and stderr on one pipe, `env` added to the environment and
// `cwd` as working directory. The child gets SIGTERM if the launcher dies.
// Throws std::system_error if fork or pipe fails; a failed exec shows as exit
// code 127 with the reason on the pipe.
Spawned spawn(const std::vector<std::string>& argv, const std::map<std::string, std::string>& env,
              const std::filesystem::path& cwd);

// Signal a child's whole process group (and SIGCONT it, so a stopped process
// sees a SIGTERM). Returns false if nothing was left to signal.
bool signal_group(pid_t pid, int sig);

// Exit code of a wait status: the code, or 128 + signal number.
int exit_code_of(int wait_status);

// Splits a byte stream into lines; over-long lines are cut at `max_line`
// so a process printing without newlines cannot grow memory.
class LineBuffer {
 public:
  explicit LineBuffer(std::size_t max_line = 4096) : max_line_(max_line) {}
  void feed(const char* data, std::size_t size, const std::function<void(const std::string&)>& on_line);
  // Emits an unterminated last line, if any.
  void flush(const std::function<void(const std::string&)>& on_line);

 private:
  std::size_t max_line_;
  std::string partial_;
};

}  // namespace harvest::launch
