#include "launch/console.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>

namespace harvest::launch {

namespace {
std::string fit(std::string s, std::size_t w) {
  if (s.size() > w) s = s.substr(0, w > 1 ? w - 1 : 0) + (w > 0 ? "~" : "");
  s.resize(w, ' ');
  return s;
}
}  // namespace

std::string render_table(const std::vector<StatusRow>& rows, std::size_t width) {
  std::size_t name_w = 4, group_w = 5, host_w = 0;
  bool usage = false;
  for (const auto& r : rows) {
    name_w = std::max(name_w, r.name.size());
    group_w = std::max(group_w, r.group.size());
    if (!r.host.empty()) host_w = std::max(host_w, std::max<std::size_t>(4, r.host.size()));
    usage = usage || r.cpu_percent >= 0 || r.rss_bytes >= 0;
  }
  name_w = std::min<std::size_t>(name_w, 24);
  group_w = std::min<std::size_t>(group_w, 12);
  host_w = std::min<std::size_t>(host_w, 16);
  auto row = [&](const std::string& h, const std::string& n, const std::string& g, const std::string& s,
                 const std::string& cpu, const std::string& mem, const std::string& pid, const std::string& rs,
                 const std::string& ex, const std::string& hb, const std::string& msg) {
    std::string line = (host_w ? fit(h, host_w) + " " : "") + fit(n, name_w) + " " + fit(g, group_w) + " " +
                       fit(s, 13) + " " + (usage ? fit(cpu, 5) + " " + fit(mem, 7) + " " : "") + fit(pid, 8) + " " +
                       fit(rs, 8) + " " + fit(ex, 6) + " " + fit(hb, 9) + " ";
    const std::size_t rest = width > line.size() ? width - line.size() : 0;
    line += msg.size() > rest ? fit(msg, rest) : msg;
    while (!line.empty() && line.back() == ' ') line.pop_back();
    return line + "\n";
  };
  auto cpu = [](double c) {
    char b[16];
    std::snprintf(b, sizeof b, "%.0f%%", c);
    return c < 0 ? std::string("-") : std::string(b);
  };
  auto mem = [](int64_t bytes) {
    char b[24];
    std::snprintf(b, sizeof b, "%.0f MB", static_cast<double>(bytes) / (1024.0 * 1024.0));
    return bytes < 0 ? std::string("-") : std::string(b);
  };
  std::string out =
      row("HOST", "NAME", "GROUP", "STATE", "CPU", "MEM", "PID", "RESTARTS", "EXIT", "HEARTBEAT", "MESSAGE");
  for (const auto& r : rows)
    out += row(r.host, r.name, r.group, r.state, cpu(r.cpu_percent), mem(r.rss_bytes),
               r.pid > 0 ? std::to_string(r.pid) : "-", std::to_string(r.restarts),
               r.last_exit.empty() ? "-" : r.last_exit, r.heartbeat, r.message);
  return out;
}

std::string seconds_text(int64_t microseconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", static_cast<double>(microseconds) * 1e-6);
  return buf;
}

std::string prefixed_line(const std::string& source, const std::string& text) {
  // spdlog pattern of every harvest process: "%H:%M:%S.%e %l [%n] %v" (runtime/process_main.cpp).
  const std::string tag = " [" + source + "] ";
  const std::size_t level_end = text.find(' ', 13);
  const bool timed = text.size() > 13 && text[2] == ':' && text[5] == ':' && text[8] == '.' && text[12] == ' ' &&
                     std::isdigit(static_cast<unsigned char>(text[0]));
  if (timed && level_end != std::string::npos && text.compare(level_end, tag.size(), tag) == 0)
    return "[" + source + "] " + text.substr(0, level_end + 1) + text.substr(level_end + tag.size());
  return "[" + source + "] " + text;
}

void Console::erase_table() {
  // Cursor up over the old table, then clear to the end of the screen.
  if (live_ && table_lines_ > 0) out_ << "\033[" << table_lines_ << "F\033[J";
}

void Console::line(const std::string& source, const std::string& text) {
  erase_table();
  out_ << prefixed_line(source, text) << "\n";
  if (live_ && table_lines_ > 0) out_ << table_;
  out_.flush();
}

void Console::table(const std::string& text) {
  if (!live_) return;
  erase_table();
  table_ = text;
  table_lines_ = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  out_ << table_;
  out_.flush();
}

}  // namespace harvest::launch
