#include "runtime/log_io.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>

namespace harvest::rt {

namespace {
constexpr uint32_t kSyncWord = 0xEDA1DA01;               // each event of an lcm-logger log begins with it
constexpr std::size_t kEventHeader = 4 + 8 + 8 + 4 + 4;  // sync, event number, timestamp, channel length, data length

uint64_t big_endian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}
}  // namespace

LogReader::LogReader(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open log " + path);
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    throw std::runtime_error("cannot open log " + path);
  }
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ > 0) {
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      ::close(fd);
      throw std::runtime_error("cannot map log " + path);
    }
    ::madvise(m, size_, MADV_SEQUENTIAL);
    base_ = static_cast<const uint8_t*>(m);
  }
  ::close(fd);  // the mapping keeps the file
}

LogReader::~LogReader() {
  if (base_ != nullptr) ::munmap(const_cast<uint8_t*>(base_), size_);
}

const LogView* LogReader::next() {
  while (pos_ + kEventHeader <= size_) {
    const uint8_t* p = base_ + pos_;
    if (big_endian(p, 4) != kSyncWord) {  // damaged: on to the next sync word, as lcm's reader does
      ++pos_;
      continue;
    }
    const auto channel_len = static_cast<int32_t>(big_endian(p + 20, 4));
    const auto data_len = static_cast<int32_t>(big_endian(p + 24, 4));
    if (channel_len <= 0 || data_len < 0) {
      ++pos_;
      continue;
    }
    const std::size_t end =
        pos_ + kEventHeader + static_cast<std::size_t>(channel_len) + static_cast<std::size_t>(data_len);
    if (end > size_) break;  // truncated: the logger stopped mid-event
    view_.timestamp = static_cast<Micros>(big_endian(p + 12, 8));
    view_.channel =
        std::string_view(reinterpret_cast<const char*>(p + kEventHeader), static_cast<std::size_t>(channel_len));
    view_.data = p + kEventHeader + channel_len;
    view_.size = static_cast<std::size_t>(data_len);
    pos_ = end;
    return &view_;
  }
  pos_ = size_;
  return nullptr;
}

std::vector<LogRecord> read_log(const std::string& path) {
  LogReader f(path);
  std::vector<LogRecord> out;
  for (const LogView* ev = f.next(); ev != nullptr; ev = f.next())
    out.push_back({ev->timestamp, std::string(ev->channel), std::vector<uint8_t>(ev->data, ev->data + ev->size)});
  return out;
}

bool write_event(lcm::LogFile& f, Micros timestamp, const std::string& channel, const void* data, std::size_t size) {
  lcm::LogEvent ev{};
  ev.timestamp = timestamp;
  ev.channel = channel;
  ev.datalen = static_cast<int32_t>(size);
  ev.data = const_cast<void*>(data);
  return f.writeEvent(&ev) == 0;
}

void write_log(const std::string& path, const std::vector<LogRecord>& records) {
  lcm::LogFile f(path, "w");
  if (!f.good()) throw std::runtime_error("cannot create log " + path);
  for (const auto& r : records)
    if (!write_event(f, r.timestamp, r.channel, r.data.data(), r.data.size()))
      throw std::runtime_error("cannot write log " + path);
}

std::size_t copy_log_from(const std::string& in, const std::string& out, Micros from) {
  LogReader r(in);
  lcm::LogFile f(out, "w");
  if (!f.good()) throw std::runtime_error("cannot create log " + out);
  std::size_t before = 0;
  std::string channel;  // reused: no allocation per event
  for (const LogView* ev = r.next(); ev != nullptr; ev = r.next()) {
    if (ev->timestamp < from) {
      ++before;
      continue;
    }
    channel.assign(ev->channel);
    if (!write_event(f, ev->timestamp, channel, ev->data, ev->size))
      throw std::runtime_error("cannot write log " + out);
  }
  return before;
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
  if (a.size() != b.size()) return "event count " + std::to_string(a.size()) + " vs " + std::to_string(b.size());
  return std::nullopt;
}

}  // namespace harvest::rt
