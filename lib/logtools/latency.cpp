#include "logtools/latency.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "logtools/reflect.hpp"
#include "runtime/json.hpp"

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
  d.min_ms = static_cast<double>(v.front()) * 1e-3;
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

namespace {

// The phase of a timer with this period that the publication times follow (each at or after its tick): most
// ticks run on time, so their residues modulo the period crowd just after the phase: it is taken where the crowd
// around the densest window of a fortieth of the period (0.5 ms of 20) begins. An estimate: a node late for most
// of its ticks would move it.
int64_t timer_phase(std::vector<int64_t> publish, int64_t period) {
  for (auto& p : publish) p = ((p % period) + period) % period;
  std::sort(publish.begin(), publish.end());
  const std::size_t n = publish.size();
  const int64_t width = std::max<int64_t>(period / 40, 1);
  std::size_t best = 0, best_count = 0, end = 0;
  for (std::size_t i = 0; i < n; ++i) {
    // Residues in [publish[i], publish[i] + width), around the circle.
    if (end < i + 1) end = i + 1;
    while (end < i + n && (publish[end % n] - publish[i] + (end >= n ? period : 0)) < width) ++end;
    if (end - i > best_count) {
      best_count = end - i;
      best = i;
    }
  }
  // Back to where that crowd begins (a timer rounded to milliseconds spreads on-time ticks over one), through
  // residues closer than a fifth of the window, at most a quarter period.
  const int64_t step = std::max<int64_t>(width / 5, 1);
  int64_t back = 0;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const std::size_t prev = (best + n - 1) % n;
    const int64_t gap = ((publish[best] - publish[prev]) % period + period) % period;
    if (gap >= step || back + gap > period / 4) break;
    back += gap;
    best = prev;
  }
  return publish[best];
}

// Where each root frame's trace leads: the stages from its sensing to the first command that used it.
void trace_chains(const std::vector<Stamp>& stamps, const std::vector<int>& input, int64_t period,
                  LatencyReport& report) {
  const std::string& end = report.command_channel;
  // Commands traced to an input, in publication order, and the channel they name.
  std::vector<int> commands;
  for (int i = 0; i < static_cast<int>(stamps.size()); ++i)
    if (stamps[i].channel == end && input[i] >= 0) commands.push_back(i);
  if (commands.empty()) return;
  std::stable_sort(commands.begin(), commands.end(),
                   [&](int a, int b) { return stamps[a].publish < stamps[b].publish; });
  std::map<std::string, int64_t> named_count;
  for (int c : commands) ++named_count[stamps[input[c]].channel];
  const std::string named = std::max_element(named_count.begin(), named_count.end(), [](const auto& a, const auto& b) {
                              return a.second < b.second;
                            })->first;
  // The first command computed with `x` (a message on the named channel) in its node's state.
  auto first_command = [&](const Stamp& x) -> int {
    for (int c : commands)
      if (stamps[input[c]].channel == named && stamps[c].source_seq >= x.seq && stamps[c].publish >= x.publish)
        return c;
    return -1;
  };
  // With the command node's timer period: when each command's tick was due.
  std::map<int, int64_t> due;
  if (period > 0) {
    std::vector<int64_t> publish;
    for (int c : commands) publish.push_back(stamps[c].publish);
    const int64_t phase = timer_phase(publish, period);
    std::vector<int64_t> late;
    for (int c : commands) {
      const int64_t l = ((stamps[c].publish - phase) % period + period) % period;
      due[c] = stamps[c].publish - l;
      late.push_back(l);
    }
    report.command_tick = distribution(std::move(late));
  }
  // Frames sensed before the one the first command names were superseded before any command went out.
  int first_root = input[commands.front()];
  while (input[first_root] >= 0) first_root = input[first_root];
  const int64_t window_start = stamps[first_root].utime;
  std::vector<std::vector<int>> children(stamps.size());
  for (int i = 0; i < static_cast<int>(stamps.size()); ++i)
    if (input[i] >= 0) children[input[i]].push_back(i);

  struct Frame {
    int root, reached;  // the deepest message of its trace towards the command
    int command;        // -1: none used it
  };
  std::map<std::string, std::vector<Frame>> frames;  // by root channel
  for (int r = 0; r < static_cast<int>(stamps.size()); ++r) {
    if (stamps[r].source_seq >= 0 || input[r] >= 0) continue;
    // Down the trace (breadth first), to its first message on the named channel.
    std::vector<int> level{r};
    int reached = r, hit = -1;
    while (!level.empty() && hit < 0) {
      std::vector<int> next;
      for (int i : level)
        for (int ch : children[i]) {
          if (stamps[ch].channel == end) continue;
          if (stamps[ch].channel == named && (hit < 0 || stamps[ch].seq < stamps[hit].seq)) hit = ch;
          next.push_back(ch);
        }
      if (!next.empty()) reached = next.front();
      level = std::move(next);
    }
    if (hit >= 0) reached = hit;
    frames[stamps[r].channel].push_back({r, reached, hit >= 0 ? first_command(stamps[hit]) : -1});
  }

  for (auto& [root_channel, list] : frames) {
    // Only channels whose frames reach a command; the window is from the frame the first command names to the
    // last frame a command used.
    int64_t last = INT64_MIN;
    for (const Frame& f : list)
      if (f.command >= 0) last = std::max(last, stamps[f.root].utime);
    if (last < window_start) continue;
    ChainLatency chain;
    std::vector<int64_t> e2e, processing, upstream, transport, command_transport, own;
    std::map<std::string, std::vector<int64_t>> stage_values;
    std::vector<std::string> stage_order;
    auto add_stage = [&](const std::string& name, int64_t v) {
      if (!stage_values.count(name)) stage_order.push_back(name);
      stage_values[name].push_back(v);
    };
    for (const Frame& f : list) {
      const Stamp& root = stamps[f.root];
      if (root.utime < window_start || root.utime > last) continue;
      ++chain.frames;
      if (f.command < 0) {
        // Where the trace stopped: the next channel the commanded frames of this camera went through.
        std::string missing = named;
        if (stamps[f.reached].channel != named) {
          for (const Frame& g : list)
            if (g.command >= 0) {
              int m = input[g.command];
              while (m >= 0 && input[m] >= 0 && stamps[input[m]].channel != stamps[f.reached].channel) m = input[m];
              if (m >= 0) missing = stamps[m].channel;
              break;
            }
        } else {
          missing = "a later " + end;
        }
        ++chain.lost["no " + missing];
        continue;
      }
      ++chain.commanded;
      // The path: root, ..., the named message (the frame's own), then the command.
      std::vector<int> path{f.reached};
      while (input[path.back()] >= 0) path.push_back(input[path.back()]);
      std::reverse(path.begin(), path.end());
      const Stamp& cmd = stamps[f.command];
      if (chain.path.empty()) {
        for (int i : path) chain.path += stamps[i].channel + " > ";
        chain.path += end;
      }
      int64_t proc = root.publish - root.utime, trans = 0;
      add_stage("sensed -> " + root.channel + " published", root.publish - root.utime);
      for (std::size_t k = 0; k < path.size(); ++k) {
        const Stamp& a = stamps[path[k]];
        const Stamp& b = k + 1 < path.size() ? stamps[path[k + 1]] : cmd;
        if (k + 1 == path.size()) upstream.push_back(proc);
        add_stage(a.channel + " transport", a.received - a.publish);
        if (&b == &cmd && period > 0) {
          // Received, then waiting for the tick (none if the tick was late and found it), then the tick's work.
          const int64_t start = std::max(due.at(f.command), a.received);
          add_stage(b.channel + " node: received -> timer due", start - a.received);
          add_stage(b.channel + " node: timer due -> published", b.publish - start);
          own.push_back(proc + b.publish - start);
        } else {
          add_stage(b.channel + " node: received -> published", b.publish - a.received);
        }
        trans += a.received - a.publish;
        proc += b.publish - a.received;
      }
      e2e.push_back(cmd.publish - root.utime);
      processing.push_back(proc);
      transport.push_back(trans);
      command_transport.push_back(cmd.received - cmd.publish);
    }
    chain.end_to_end = distribution(std::move(e2e));
    chain.processing = distribution(std::move(processing));
    chain.upstream = distribution(std::move(upstream));
    chain.own = distribution(std::move(own));
    chain.transport = distribution(std::move(transport));
    chain.command_transport = distribution(std::move(command_transport));
    for (const auto& name : stage_order) chain.stages.emplace_back(name, distribution(std::move(stage_values[name])));
    report.chains[root_channel] = std::move(chain);
  }
}

}  // namespace

LatencyReport latency(const std::vector<rt::LogRecord>& log, const LatencyOptions& options) {
  LatencyReport report;
  report.command_channel = options.command_channel;
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
  std::map<std::string, std::vector<int64_t>> hops, hop_processing;
  std::vector<int> inputs(stamps.size(), -1);  // index of each message's input
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    const Stamp& s = stamps[i];
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
    inputs[i] = static_cast<int>(input - stamps.data());
    const std::string hop = input->channel + " -> " + s.channel;
    hops[hop].push_back(s.publish - input->publish);
    hop_processing[hop].push_back(s.publish - input->received);
  }
  for (auto& [name, v] : hops) report.hops[name] = distribution(std::move(v));
  for (auto& [name, v] : hop_processing) report.hop_processing[name] = distribution(std::move(v));
  trace_chains(stamps, inputs, options.command_period_us, report);
  return report;
}

std::string format_latency(const std::string& path, const LatencyReport& report) {
  std::ostringstream out;
  char line[256];
  auto row = [&](const std::string& name, const Distribution& d) {
    std::snprintf(line, sizeof line, "  %-46s %8lld %9.3f %9.3f %9.3f\n", name.c_str(), static_cast<long long>(d.count),
                  d.p50_ms, d.p99_ms, d.max_ms);
    out << line;
  };
  out << path << "\n";
  std::snprintf(line, sizeof line, "  %-46s %8s %9s %9s %9s\n", "", "count", "p50 ms", "p99 ms", "max ms");
  const std::string header = line;
  out << "age at publication (publish_utime - utime: from sensing)\n" << header;
  for (const auto& [channel, c] : report.channels)
    if (c.age.count > 0) row(channel, c.age);
  out << "transport (log time - publish_utime: publication to the logger's receipt)\n" << header;
  for (const auto& [channel, c] : report.channels) row(channel, c.transport);
  out << "hops (input's publication to the output's, traced by utime and source_seq)\n" << header;
  for (const auto& [name, d] : report.hops) row(name, d);
  out << "hop processing (the logger's receipt of the input, for the node's, to the output's publication)\n" << header;
  for (const auto& [name, d] : report.hop_processing) row(name, d);
  if (report.command_tick.count > 0) {
    out << report.command_channel << " after its timer was due (the timer's phase estimated from the commands)\n"
        << header;
    row("all " + report.command_channel, report.command_tick);
  }
  for (const auto& [root, c] : report.chains) {
    out << "frame -> first " << report.command_channel << " that used it: " << c.path << "\n";
    out << "  " << c.commanded << " of " << c.frames << " frames in the window used";
    for (const auto& [why, n] : c.lost) out << ", " << n << " " << why;
    out << "\n" << header;
    row("end to end (utime -> command published)", c.end_to_end);
    row("  processing (sum)", c.processing);
    row("    up to the command's input", c.upstream);
    if (c.own.count > 0) row("    without the wait for the timer", c.own);
    row("  transport (sum)", c.transport);
    for (const auto& [name, d] : c.stages) row("  " + name, d);
    row("  (after) " + report.command_channel + " transport", c.command_transport);
  }
  if (report.untraced > 0) {
    out << "  " << report.untraced << " derived messages whose input is not in the log:";
    for (const auto& [channel, n] : report.untraced_by_channel) out << " " << channel << " " << n;
    out << "\n";
  }
  if (report.unstamped > 0) out << "  " << report.unstamped << " messages without publish_utime left out\n";
  if (report.malformed > 0) out << "  " << report.malformed << " malformed events left out\n";
  return out.str();
}

namespace {

rt::Json to_json(const Distribution& d) {
  rt::Json j;
  j["count"] = d.count;
  j["min_ms"] = rt::json_number(d.min_ms, 3);
  j["p50_ms"] = rt::json_number(d.p50_ms, 3);
  j["p99_ms"] = rt::json_number(d.p99_ms, 3);
  j["max_ms"] = rt::json_number(d.max_ms, 3);
  return j;
}

}  // namespace

std::string latency_json(const std::string& path, const LatencyReport& report) {
  rt::Json j;
  j["log"] = path;
  for (const auto& [channel, c] : report.channels) {
    if (c.age.count > 0) j["age"][channel] = to_json(c.age);
    j["transport"][channel] = to_json(c.transport);
  }
  for (const auto& [name, d] : report.hops) j["hops"][name] = to_json(d);
  for (const auto& [name, d] : report.hop_processing) j["hop_processing"][name] = to_json(d);
  j["command_channel"] = report.command_channel;
  if (report.command_tick.count > 0) j["command_tick"] = to_json(report.command_tick);
  j["chains"] = rt::Json::object();
  for (const auto& [root, c] : report.chains) {
    rt::Json& o = j["chains"][root];
    o["path"] = c.path;
    o["frames"] = c.frames;
    o["commanded"] = c.commanded;
    o["lost"] = rt::Json::object();
    for (const auto& [why, n] : c.lost) o["lost"][why] = n;
    o["end_to_end"] = to_json(c.end_to_end);
    o["processing"] = to_json(c.processing);
    o["upstream_processing"] = to_json(c.upstream);
    if (c.own.count > 0) o["own_processing"] = to_json(c.own);
    o["transport"] = to_json(c.transport);
    o["stages"] = rt::Json::array();
    for (const auto& [name, d] : c.stages) {
      rt::Json st = to_json(d);
      st["stage"] = name;
      o["stages"].push_back(st);
    }
    o["command_transport"] = to_json(c.command_transport);
  }
  j["untraced"] = report.untraced;
  j["untraced_by_channel"] = rt::Json::object();
  for (const auto& [channel, n] : report.untraced_by_channel) j["untraced_by_channel"][channel] = n;
  j["unstamped"] = report.unstamped;
  j["malformed"] = report.malformed;
  return rt::json_pretty(j);
}

}  // namespace harvest::logtools
