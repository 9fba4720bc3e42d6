#include "logtools/latency.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "logtools/reflect.hpp"

namespace harvest::logtools {

Distribution distribution(std::vector<int64_t> v) {
  Distribution d;
  d.count = static_cast<int64_t>(v.size());
  if (v.empty()) return d;
  std::sort(v.begin(), v.end());
  auto rank = [&](double p) {
    const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
    return static_cast<double>(v[std::clamp<std::size_t>(k, 1, v.size()) - 1]) * 1e-3;
  };
  d.p50_ms = rank(0.50);
  d.p99_ms = rank(0.99);
  d.max_ms = static_cast<double>(v.back()) * 1e-3;
  return d;
}

namespace {

struct Stamp {
  std::string channel, frame_id;
  int64_t utime = 0, seq = 0, source_seq = -1, publish = 0, received = 0;
};

}  // namespace

LatencyReport latency(const std::vector<rt::LogRecord>& log) {
  LatencyReport report;
  std::vector<Stamp> stamps;
  for (const auto& r : log) {
    const auto fp = fingerprint(r.data.data(), r.data.size());
    if (!fp || !type_by_hash(*fp)) continue;  // not a harvest message (another tool's channel)
    const auto d = decode_any(r.data.data(), r.data.size());
    if (!d.type) {
      ++report.malformed;
      continue;
    }
    const Field* utime = d.fields.find("header.utime");
    const Field* publish = d.fields.find("header.publish_utime");
    if (!utime || !publish) continue;  // no header
    if (publish->i <= 0) {
      ++report.unstamped;  // written by a tool that does not stamp its publication
      continue;
    }
    Stamp s;
    s.channel = r.channel;
    s.utime = utime->i;
    s.publish = publish->i;
    s.received = r.timestamp;
    if (const Field* f = d.fields.find("header.seq")) s.seq = f->i;
    if (const Field* f = d.fields.find("header.source_seq")) s.source_seq = f->i;
    if (const Field* f = d.fields.find("header.frame_id")) s.frame_id = f->s;
    stamps.push_back(std::move(s));
  }

  std::map<std::string, std::pair<std::vector<int64_t>, std::vector<int64_t>>> per_channel;
  std::multimap<std::pair<int64_t, int64_t>, const Stamp*> by_key;  // (utime, seq)
  for (const auto& s : stamps) {
    auto& [age, transport] = per_channel[s.channel];
    if (s.utime > 0) age.push_back(s.publish - s.utime);
    transport.push_back(s.received - s.publish);
    by_key.emplace(std::make_pair(s.utime, s.seq), &s);
  }
  for (auto& [channel, v] : per_channel)
    report.channels[channel] = {distribution(std::move(v.first)), distribution(std::move(v.second))};

  // The input of a derived message: same utime, its seq is our source_seq, published before us on another
  // channel. Two cameras can share a utime and a seq (the simulator's do), so a channel that is ever seen
  // fed by an input of its own frame (a detector by its camera) is only ever matched to one: with images
  // recorded at a reduced rate, a hand detection whose frame was not recorded stays untraced instead of
  // being charged to the fixed camera's frame of the same instant.
  auto candidates = [&](const Stamp& s) {
    std::vector<const Stamp*> out;
    const auto [lo, hi] = by_key.equal_range({s.utime, s.source_seq});
    for (auto it = lo; it != hi; ++it)
      if (it->second->channel != s.channel && it->second->publish <= s.publish) out.push_back(it->second);
    return out;
  };
  std::set<std::string> frame_preserving;
  for (const auto& s : stamps)
    if (s.source_seq >= 0)
      for (const Stamp* c : candidates(s))
        if (c->frame_id == s.frame_id) frame_preserving.insert(s.channel);
  std::map<std::string, std::vector<int64_t>> hops;
  for (const auto& s : stamps) {
    if (s.source_seq < 0) continue;  // raw sensor data
    const bool same_frame = frame_preserving.count(s.channel) > 0;
    const Stamp* input = nullptr;
    for (const Stamp* c : candidates(s))
      if ((!same_frame || c->frame_id == s.frame_id) && (!input || c->publish > input->publish)) input = c;
    if (!input) {
      ++report.untraced;
      ++report.untraced_by_channel[s.channel];
      continue;
    }
    hops[input->channel + " -> " + s.channel].push_back(s.publish - input->publish);
  }
  for (auto& [name, v] : hops) report.hops[name] = distribution(std::move(v));
  return report;
}

std::string format_latency(const std::string& path, const LatencyReport& report) {
  std::ostringstream out;
  char line[256];
  auto row = [&](const std::string& name, const Distribution& d) {
    std::snprintf(line, sizeof line, "  %-40s %8lld %9.3f %9.3f %9.3f\n", name.c_str(), static_cast<long long>(d.count),
                  d.p50_ms, d.p99_ms, d.max_ms);
    out << line;
  };
  out << path << "\n";
  std::snprintf(line, sizeof line, "  %-40s %8s %9s %9s %9s\n", "", "count", "p50 ms", "p99 ms", "max ms");
  const std::string header = line;
  out << "age at publication (publish_utime - utime: from sensing)\n" << header;
  for (const auto& [channel, c] : report.channels)
    if (c.age.count > 0) row(channel, c.age);
  out << "transport (log time - publish_utime: publication to the logger's receipt)\n" << header;
  for (const auto& [channel, c] : report.channels) row(channel, c.transport);
  out << "hops (input's publication to the output's, traced by utime and source_seq)\n" << header;
  for (const auto& [name, d] : report.hops) row(name, d);
  if (report.untraced > 0) {
    out << "  " << report.untraced << " derived messages whose input is not in the log:";
    for (const auto& [channel, n] : report.untraced_by_channel) out << " " << channel << " " << n;
    out << "\n";
  }
  if (report.unstamped > 0) out << "  " << report.unstamped << " messages without publish_utime left out\n";
  if (report.malformed > 0) out << "  " << report.malformed << " malformed events left out\n";
  return out.str();
}

}  // namespace harvest::logtools
