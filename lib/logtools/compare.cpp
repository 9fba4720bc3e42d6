#include "logtools/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "logtools/reflect.hpp"

namespace harvest::logtools {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Msg {
  std::size_t index = 0;
  const rt::LogRecord* rec = nullptr;
  Decoded decoded;
  bool has_utime = false;
  int64_t utime = 0;
};

std::vector<Msg> channel_messages(const std::vector<rt::LogRecord>& log, const std::string& channel) {
  std::vector<Msg> out;
  for (const auto& r : log) {
    if (r.channel != channel) continue;
    Msg m;
    m.index = out.size();
    m.rec = &r;
    m.decoded = decode_any(r.data.data(), r.data.size());
    if (const Field* f = m.decoded.fields.find("header.utime")) {
      m.has_utime = true;
      m.utime = f->i;
    }
    out.push_back(std::move(m));
  }
  return out;
}

// Strips the last component of a generic path: "a.b[]" -> "a.b", "a.b" -> "a".
std::string parent_path(const std::string& p) {
  if (p.size() >= 2 && p.compare(p.size() - 2, 2, "[]") == 0) return p.substr(0, p.size() - 2);
  auto dot = p.rfind('.');
  return dot == std::string::npos ? std::string() : p.substr(0, dot);
}

std::string fmt_tol(double t) {
  if (std::isinf(t)) return "ignored";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", t);
  return buf;
}

void compare_fields(const std::string& channel, const Fields& a, const Fields& b, const CompareOptions& o,
                    MessageDiff& out) {
  std::unordered_map<std::string, const Field*> bmap;
  for (const auto& f : b.items()) bmap.emplace(f.path, &f);
  auto note = [&](FieldDiff d) {
    ++out.num_fields;
    if (out.fields.size() < o.max_fields_per_message) out.fields.push_back(std::move(d));
  };
  for (const auto& fa : a.items()) {
    if (fa.path == "header.publish_utime") continue;
    const double* tol = o.tolerance_for(channel, fa.path);
    if (tol != nullptr && std::isinf(*tol)) continue;
    auto it = bmap.find(fa.path);
    if (it == bmap.end()) {
      note({fa.path, value_text(fa), "(absent)", std::numeric_limits<double>::quiet_NaN(), 0});
      continue;
    }
    const Field& fb = *it->second;
    bmap.erase(it);
    bool equal = true;
    double delta = std::numeric_limits<double>::quiet_NaN();
    double limit = 0;
    switch (fa.kind) {
      case FieldKind::kInt:
      case FieldKind::kBool:
        delta = std::fabs(static_cast<double>(fa.i) - static_cast<double>(fb.i));
        limit = tol ? *tol : 0;
        equal = fa.i == fb.i || delta <= limit;
        break;
      case FieldKind::kFloat:
      case FieldKind::kDouble: {
        if (std::isnan(fa.d) && std::isnan(fb.d)) break;
        delta = std::fabs(fa.d - fb.d);
        const double rel = fa.kind == FieldKind::kFloat ? o.float_relative : o.double_relative;
        limit = tol ? *tol : rel * std::max({1.0, std::fabs(fa.d), std::fabs(fb.d)});
        equal = fa.d == fb.d || delta <= limit;
        break;
      }
      case FieldKind::kString:
      case FieldKind::kBytes:
        equal = fa.s == fb.s;
        break;
    }
    if (equal) continue;
    FieldDiff d{fa.path, value_text(fa), value_text(fb), delta, limit};
    if (fa.kind == FieldKind::kBytes) {
      std::size_t k = 0;
      while (k < fa.s.size() && k < fb.s.size() && fa.s[k] == fb.s[k]) ++k;
      d.replayed += " (first difference at byte " + std::to_string(k) + ")";
    }
    note(std::move(d));
  }
  for (const auto& fb : b.items()) {
    if (!bmap.count(fb.path) || fb.path == "header.publish_utime") continue;
    const double* tol = o.tolerance_for(channel, fb.path);
    if (tol != nullptr && std::isinf(*tol)) continue;
    note({fb.path, "(absent)", value_text(fb), std::numeric_limits<double>::quiet_NaN(), 0});
  }
}

}  // namespace

void CompareOptions::add_tolerance(const std::string& spec) {
  auto eq = spec.rfind('=');
  if (eq == std::string::npos || eq == 0 || spec.find('.') == std::string::npos || spec.find('.') > eq)
    throw std::invalid_argument("tolerance '" + spec +
                                "': expected CHANNEL.field=abs, e.g. TARGETS.targets[].depth_m=1e-4");
  double v = 0;
  try {
    std::size_t used = 0;
    v = std::stod(spec.substr(eq + 1), &used);
    if (used != spec.size() - eq - 1) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw std::invalid_argument("tolerance '" + spec + "': '" + spec.substr(eq + 1) + "' is not a number");
  }
  if (!(v >= 0)) throw std::invalid_argument("tolerance '" + spec + "': must be >= 0");
  tolerances[generic_path(spec.substr(0, eq))] = v;
}

void CompareOptions::add_ignore(const std::string& key) {
  if (key.empty() || key.find('.') == std::string::npos)
    throw std::invalid_argument("ignore '" + key + "': expected CHANNEL.field, e.g. '*.header.seq'");
  tolerances[generic_path(key)] = kInf;
}

const double* CompareOptions::tolerance_for(const std::string& channel, const std::string& path) const {
  if (tolerances.empty()) return nullptr;
  for (std::string g = generic_path(path); !g.empty(); g = parent_path(g)) {
    auto it = tolerances.find(channel + "." + g);
    if (it != tolerances.end()) return &it->second;
    it = tolerances.find("*." + g);
    if (it != tolerances.end()) return &it->second;
  }
  return nullptr;
}

bool ChannelReport::ok(const CompareOptions& o) const {
  if (differing > 0 || !errors.empty()) return false;
  return o.allow_unmatched || (only_recorded.empty() && only_replayed.empty());
}

bool ChannelReport::explained() const {
  if (differing > 0 || !errors.empty()) return false;
  const auto all = [](const std::vector<std::string>& why, std::size_t n) {
    return why.size() == n && std::none_of(why.begin(), why.end(), [](const std::string& w) { return w.empty(); });
  };
  return all(only_recorded_why, only_recorded.size()) && all(only_replayed_why, only_replayed.size());
}

CompareReport compare_logs(const std::vector<rt::LogRecord>& recorded, const std::vector<rt::LogRecord>& replayed,
                           const std::vector<std::string>& channels, const CompareOptions& options) {
  CompareReport report;
  for (const auto& channel : channels) {
    ChannelReport cr;
    cr.channel = channel;
    auto rec = channel_messages(recorded, channel);
    auto rep = channel_messages(replayed, channel);
    cr.recorded = rec.size();
    cr.replayed = rep.size();
    if (!rec.empty()) {
      cr.first_recorded_time = rec.front().rec->timestamp;
      cr.last_recorded_time = rec.back().rec->timestamp;
    }
    for (const auto* side : {&rec, &rep})
      for (const auto& m : *side) {
        if (m.decoded.type == nullptr)
          cr.errors.push_back((side == &rec ? "recorded #" : "replayed #") + std::to_string(m.index) + ": " +
                              m.decoded.error);
        else if (cr.type.empty())
          cr.type = m.decoded.type->name;
      }

    // Pair by utime (in order within one utime), else by position.
    std::vector<std::pair<const Msg*, const Msg*>> pairs;
    std::vector<bool> rep_used(rep.size(), false);
    std::map<int64_t, std::deque<std::size_t>> by_utime;
    for (const auto& m : rep)
      if (m.has_utime) by_utime[m.utime].push_back(m.index);
    std::size_t next_plain = 0;
    for (const auto& m : rec) {
      std::optional<std::size_t> j;
      if (m.has_utime) {
        auto it = by_utime.find(m.utime);
        if (it != by_utime.end() && !it->second.empty()) {
          j = it->second.front();
          it->second.pop_front();
        }
      } else {
        while (next_plain < rep.size() && (rep[next_plain].has_utime || rep_used[next_plain])) ++next_plain;
        if (next_plain < rep.size()) j = next_plain++;
      }
      if (j) {
        rep_used[*j] = true;
        pairs.emplace_back(&m, &rep[*j]);
      } else {
        cr.only_recorded.push_back(m.index);
        cr.only_recorded_utime.push_back(m.utime);
        cr.only_recorded_time.push_back(m.rec->timestamp);
      }
    }
    for (const auto& m : rep)
      if (!rep_used[m.index]) {
        cr.only_replayed.push_back(m.index);
        cr.only_replayed_utime.push_back(m.utime);
        cr.only_replayed_time.push_back(m.rec->timestamp);
      }

    for (const auto& [a, b] : pairs) {
      ++cr.matched;
      MessageDiff md;
      md.recorded_index = a->index;
      md.replayed_index = b->index;
      md.utime = a->utime;
      if (a->decoded.type != b->decoded.type) {
        ++md.num_fields;
        md.fields.push_back({"(type)", a->decoded.type ? a->decoded.type->name : "?",
                             b->decoded.type ? b->decoded.type->name : "?", std::numeric_limits<double>::quiet_NaN(),
                             0});
      } else if (a->decoded.type == nullptr) {
        if (a->rec->data != b->rec->data) {
          ++md.num_fields;
          md.fields.push_back({"(raw bytes)", std::to_string(a->rec->data.size()) + " bytes",
                               std::to_string(b->rec->data.size()) + " bytes", std::numeric_limits<double>::quiet_NaN(),
                               0});
        }
      } else {
        compare_fields(channel, a->decoded.fields, b->decoded.fields, options, md);
      }
      if (md.num_fields == 0) {
        ++cr.identical;
      } else {
        ++cr.differing;
        if (cr.diffs.size() < options.max_messages_per_channel) cr.diffs.push_back(std::move(md));
      }
    }
    if (!cr.ok(options)) report.ok = false;
    report.channels.push_back(std::move(cr));
  }
  return report;
}

std::string format_report(const CompareReport& report, const CompareOptions& options) {
  std::ostringstream os;
  for (const auto& c : report.channels) {
    const bool explained_only = !c.ok(options) && c.explained();
    os << (c.ok(options)    ? "SAME "
           : explained_only ? "EXPLAINED "
                            : "DIFF ")
       << c.channel << " (" << (c.type.empty() ? "no messages" : c.type) << "): recorded " << c.recorded
       << ", replayed " << c.replayed << ", paired " << c.matched << ", identical " << c.identical << ", differing "
       << c.differing << ", only recorded " << c.only_recorded.size() << ", only replayed " << c.only_replayed.size()
       << "\n";
    for (const auto& e : c.errors) os << "    undecodable " << e << "\n";
    for (const auto& d : c.diffs) {
      os << "    message recorded #" << d.recorded_index << " / replayed #" << d.replayed_index << " (utime " << d.utime
         << "): " << d.num_fields << " field" << (d.num_fields == 1 ? "" : "s") << " differ\n";
      for (const auto& f : d.fields) {
        os << "      " << c.channel << "." << f.path << ": recorded " << f.recorded << ", replayed " << f.replayed;
        if (!std::isnan(f.delta))
          os << " (|diff| " << fmt_tol(f.delta) << " > tolerance " << fmt_tol(f.tolerance) << ")";
        os << "\n";
      }
      if (d.num_fields > d.fields.size()) os << "      ... " << d.num_fields - d.fields.size() << " more fields\n";
    }
    if (c.differing > c.diffs.size()) os << "    ... " << c.differing - c.diffs.size() << " more differing messages\n";
    auto list = [&](const char* what, const std::vector<std::size_t>& idx, const std::vector<int64_t>& ut,
                    const std::vector<std::string>& why) {
      if (idx.empty()) return;
      if (why.size() != idx.size()) {  // not explained: the messages
        os << "    only " << what << ":";
        for (std::size_t k = 0; k < idx.size() && k < options.max_messages_per_channel; ++k)
          os << " #" << idx[k] << " (utime " << ut[k] << ")";
        if (idx.size() > options.max_messages_per_channel) os << " ...";
        os << "\n";
        return;
      }
      // One line per reason, with how many messages and the first few.
      std::map<std::string, std::vector<std::size_t>> by_reason;
      for (std::size_t k = 0; k < idx.size(); ++k) by_reason[why[k]].push_back(k);
      for (const auto& [reason, ks] : by_reason) {
        os << "    only " << what << " " << ks.size() << ":";
        for (std::size_t k = 0; k < ks.size() && k < 3; ++k) os << " #" << idx[ks[k]] << " (utime " << ut[ks[k]] << ")";
        if (ks.size() > 3) os << " ...";
        os << " -- " << (reason.empty() ? "NOT EXPLAINED" : reason) << "\n";
      }
    };
    list("recorded", c.only_recorded, c.only_recorded_utime, c.only_recorded_why);
    list("replayed", c.only_replayed, c.only_replayed_utime, c.only_replayed_why);
  }
  os << (report.ok          ? "replay matches the recording"
         : report.explained ? "replay matches the recording where the live nodes had the same input (every "
                              "difference explained above)"
                            : "replay DIFFERS from the recording")
     << "\n";
  return os.str();
}

}  // namespace harvest::logtools
