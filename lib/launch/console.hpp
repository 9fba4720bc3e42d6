// The launcher's terminal output: child output lines prefixed with the
// process name, and a status table. On a TTY the table is redrawn in place
// below the scrolling output; otherwise only plain lines are written (logs,
// CI, scripts).
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

namespace harvest::launch {

struct StatusRow {
  std::string name, group, state;
  int pid = -1;
  int restarts = 0;
  std::string last_exit;  // "" if it never exited
  std::string heartbeat;  // age of the last heartbeat, "-" if none expected
  std::string message;
  std::string host = "";        // the deputy it runs under (the sheriff's table); "" on one host
  double heartbeat_age_s = -1;  // -1: none yet or none expected
  double cpu_percent = -1;      // -1: not measured (the launcher's own table)
  int64_t rss_bytes = -1;
};

// A child's output line as the launcher prints it: "[source] text". A harvest
// process's own log line already names its instance after the time and level
// ("12:00:00.123 info [sim] started"); that [sim] is dropped, so each line
// names its process once and always first.
std::string prefixed_line(const std::string& source, const std::string& text);

// A duration or age as the launcher and the sheriff print it: "1.5 s".
std::string seconds_text(int64_t microseconds);

// Fixed-width table, header first, one row per process; every row ends with '\n'.
// A HOST column comes first when a row names a host, CPU and MEM columns
// after STATE when a row has them measured.
std::string render_table(const std::vector<StatusRow>& rows, std::size_t width = 120);

class Console {
 public:
  Console(std::ostream& out, bool live_table) : out_(out), live_(live_table) {}
  // One line from `source` (a process name or "launch").
  void line(const std::string& source, const std::string& text);
  // Replace the table (TTY only; ignored otherwise).
  void table(const std::string& text);
  bool live() const { return live_; }

 private:
  void erase_table();
  std::ostream& out_;
  bool live_;
  std::string table_;
  int table_lines_ = 0;
};

}  // namespace harvest::launch
