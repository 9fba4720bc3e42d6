#include "logtools/log_info.hpp"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <set>
#include <sstream>

#include "logtools/reflect.hpp"

namespace harvest::logtools {

std::string utc_text(int64_t utime) {
  std::time_t s = static_cast<std::time_t>(utime / 1'000'000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
  char out[96];
  std::snprintf(out, sizeof out, "%s.%06lld UTC", buf,
                static_cast<long long>(((utime % 1'000'000) + 1'000'000) % 1'000'000));
  return out;
}

LogInfo log_info(const std::vector<rt::LogRecord>& log, const InfoOptions& options) {
  LogInfo info;
  struct Acc {
    ChannelInfo ci;
    std::vector<int64_t> times;
    std::set<std::string> types;
  };
  std::map<std::string, Acc> acc;
  int64_t prev = 0;
  for (const auto& r : log) {
    if (info.events == 0) info.first = r.timestamp;
    if (info.events > 0 && r.timestamp < prev) ++info.non_monotonic;
    prev = r.timestamp;
    info.first = std::min(info.first, r.timestamp);
    info.last = std::max(info.last, r.timestamp);
    ++info.events;
    info.bytes += static_cast<int64_t>(r.data.size());
    Acc& a = acc[r.channel];
    a.ci.channel = r.channel;
    ++a.ci.count;
    a.ci.bytes += static_cast<int64_t>(r.data.size());
    a.times.push_back(r.timestamp);
    auto fp = fingerprint(r.data.data(), r.data.size());
    const TypeInfo* t = fp ? type_by_hash(*fp) : nullptr;
    if (t != nullptr) {
      a.types.insert(t->name);
      Fields ignore;
      if (!t->flatten(r.data.data(), r.data.size(), ignore, nullptr)) ++a.ci.decode_errors;
    } else {
      a.types.insert(fp ? "unknown " + hex_fingerprint(*fp) : "unknown (short)");
    }
  }
  for (auto& [name, a] : acc) {
    ChannelInfo& c = a.ci;
    for (const auto& t : a.types) c.type += (c.type.empty() ? "" : "|") + t;
    std::sort(a.times.begin(), a.times.end());
    c.first = a.times.front();
    c.last = a.times.back();
    if (a.times.size() >= 2 && c.last > c.first)
      c.rate_hz = static_cast<double>(a.times.size() - 1) / (static_cast<double>(c.last - c.first) * 1e-6);
    std::vector<int64_t> iv;
    for (std::size_t k = 1; k < a.times.size(); ++k) iv.push_back(a.times[k] - a.times[k - 1]);
    if (!iv.empty()) {
      std::vector<int64_t> sorted = iv;
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
      c.median_interval = sorted[sorted.size() / 2];
      c.max_interval = *std::max_element(iv.begin(), iv.end());
      const double limit = std::max(static_cast<double>(options.min_gap_us),
                                    options.gap_factor * static_cast<double>(c.median_interval));
      for (std::size_t k = 0; k < iv.size(); ++k)
        if (static_cast<double>(iv[k]) > limit) c.gaps.push_back({a.times[k], iv[k]});
    }
    info.channels.push_back(std::move(c));
  }
  return info;
}

std::string format_info(const std::string& path, const LogInfo& info, std::size_t max_gaps) {
  std::ostringstream os;
  char buf[512];
  const double span = static_cast<double>(info.last - info.first) * 1e-6;
  os << "log      " << path << "\n";
  std::snprintf(buf, sizeof buf, "events   %lld (%.1f MB of message data)\n", static_cast<long long>(info.events),
                static_cast<double>(info.bytes) / 1e6);
  os << buf;
  if (info.events > 0) {
    os << "start    " << utc_text(info.first) << "\n";
    os << "end      " << utc_text(info.last) << "\n";
    std::snprintf(buf, sizeof buf, "duration %.3f s\n", span);
    os << buf;
  }
  if (info.non_monotonic > 0) os << "warning  " << info.non_monotonic << " events go back in time\n";
  std::size_t w = 7;
  std::size_t tw = 4;
  for (const auto& c : info.channels) {
    w = std::max(w, c.channel.size());
    tw = std::max(tw, c.type.size());
  }
  std::snprintf(buf, sizeof buf, "\n%-*s  %-*s %8s %9s %10s %9s %9s %10s %4s\n", static_cast<int>(w), "channel",
                static_cast<int>(tw), "type", "count", "rate_Hz", "bytes", "first_s", "last_s", "max_gap_s", "gaps");
  os << buf;
  for (const auto& c : info.channels) {
    std::snprintf(buf, sizeof buf, "%-*s  %-*s %8lld %9.2f %10lld %9.3f %9.3f %10.3f %4zu\n", static_cast<int>(w),
                  c.channel.c_str(), static_cast<int>(tw), c.type.c_str(), static_cast<long long>(c.count), c.rate_hz,
                  static_cast<long long>(c.bytes), static_cast<double>(c.first - info.first) * 1e-6,
                  static_cast<double>(c.last - info.first) * 1e-6, static_cast<double>(c.max_interval) * 1e-6,
                  c.gaps.size());
    os << buf;
  }
  bool any = false;
  for (const auto& c : info.channels) {
    if (c.decode_errors > 0) os << "\n" << c.channel << ": " << c.decode_errors << " malformed messages\n";
    if (c.gaps.empty()) continue;
    if (!any) os << "\ngaps (longer than 5 median intervals and 0.2 s):\n";
    any = true;
    for (std::size_t k = 0; k < c.gaps.size() && k < max_gaps; ++k) {
      std::snprintf(buf, sizeof buf, "  %-*s at %.3f s: %.3f s without a message\n", static_cast<int>(w),
                    c.channel.c_str(), static_cast<double>(c.gaps[k].start - info.first) * 1e-6,
                    static_cast<double>(c.gaps[k].length) * 1e-6);
      os << buf;
    }
    if (c.gaps.size() > max_gaps) os << "  " << c.channel << ": " << c.gaps.size() - max_gaps << " more\n";
  }
  return os.str();
}

}  // namespace harvest::logtools
