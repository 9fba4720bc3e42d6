#include "runtime/log_io.hpp"

#include <lcm/lcm-cpp.hpp>

#include <stdexcept>

namespace harvest::rt {

std::vector<LogRecord> read_log(const std::string& path) {
  lcm::LogFile f(path, "r");
  if (!f.good()) throw std::runtime_error("cannot open log " + path);
  std::vector<LogRecord> out;
  for (const lcm::LogEvent* ev = f.readNextEvent(); ev != nullptr; ev = f.readNextEvent()) {
    const auto* p = static_cast<const uint8_t*>(ev->data);
    out.push_back({ev->timestamp, ev->channel, std::vector<uint8_t>(p, p + ev->datalen)});
  }
  return out;
}

void write_log(const std::string& path, const std::vector<LogRecord>& records) {
  lcm::LogFile f(path, "w");
  if (!f.good()) throw std::runtime_error("cannot create log " + path);
  for (const auto& r : records) {
    lcm::LogEvent ev{};
    ev.timestamp = r.timestamp;
    ev.channel = r.channel;
    ev.datalen = static_cast<int32_t>(r.data.size());
    ev.data = const_cast<uint8_t*>(r.data.data());
    if (f.writeEvent(&ev) != 0) throw std::runtime_error("cannot write log " + path);
  }
}

std::optional<std::string> first_difference(const std::vector<LogRecord>& a, const std::vector<LogRecord>& b) {
  const std::size_t n = std::min(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (a[i].channel != b[i].channel)
      return "event " + std::to_string(i) + ": channel " + a[i].channel + " vs " + b[i].channel;
    if (a[i].timestamp != b[i].timestamp)
      return "event " + std::to_string(i) + " (" + a[i].channel + "): timestamp " + std::to_string(a[i].timestamp) +
             " vs " + std::to_string(b[i].timestamp);
    if (a[i].data != b[i].data) return "event " + std::to_string(i) + " (" + a[i].channel + "): payload differs";
  }
  if (a.size() != b.size())
    return "event count " + std::to_string(a.size()) + " vs " + std::to_string(b.size());
  return std::nullopt;
}

}  // namespace harvest::rt
