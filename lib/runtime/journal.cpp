#include "runtime/journal.hpp"

#include <algorithm>
#include <stdexcept>

#include "runtime/log_io.hpp"

namespace harvest::rt {

int64_t journal_key(const void* data, std::size_t size) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](uint8_t b) {
    h ^= b;
    h *= 1099511628211ull;
  };
  for (int i = 0; i < 8; ++i) mix(static_cast<uint8_t>(size >> (8 * i)));
  const auto* p = static_cast<const uint8_t*>(data);
  for (std::size_t i = 0, n = std::min<std::size_t>(size, 256); i < n; ++i) mix(p[i]);
  return static_cast<int64_t>(h);
}

int32_t JournalWriter::name_id(const std::string& name) {
  const auto it = ids_.find(name);
  if (it != ids_.end()) return it->second;
  names_.push_back(name);
  return ids_.emplace(name, static_cast<int32_t>(names_.size() - 1)).first->second;
}

void JournalWriter::message(const std::string& channel, const void* data, std::size_t size, Micros t) {
  if (entries_.empty()) first_ = t;
  entries_.push_back({false, name_id(channel), journal_key(data, size), t});
}

void JournalWriter::timer(const std::string& label, Micros t) {
  if (entries_.empty()) first_ = t;
  entries_.push_back({true, name_id(label), 0, t});
}

node_journal_t JournalWriter::take(Micros now) {
  node_journal_t m{};
  m.header.utime = now;
  m.header.seq = seq_++;
  m.header.source_seq = -1;
  m.header.publish_utime = now;
  m.instance = instance_;
  m.n_repeat = static_cast<int32_t>(previous_.size());
  std::vector<int32_t> index(names_.size(), -1);  // writer's name -> the record's
  for (const auto* part : {&previous_, &entries_})
    for (const Entry& e : *part) {
      auto& i = index[static_cast<std::size_t>(e.name)];
      if (i < 0) {
        i = static_cast<int32_t>(m.names.size());
        m.names.push_back(names_[static_cast<std::size_t>(e.name)]);
      }
      m.kind.push_back(e.timer ? 1 : 0);
      m.name.push_back(i);
      m.key.push_back(e.key);
      m.utime.push_back(e.utime);
    }
  m.n_names = static_cast<int32_t>(m.names.size());
  m.n = static_cast<int32_t>(m.kind.size());
  std::swap(previous_, entries_);  // both keep their capacity
  entries_.clear();
  return m;
}

std::map<std::string, Journal> read_journals(const std::string& log_path, const std::string& prefix) {
  LogReader in(log_path);
  std::map<std::string, Journal> out;
  std::map<std::string, int64_t> next_seq;
  const std::string channel = prefix + kJournalChannel;
  node_journal_t m;  // reused: its vectors keep their capacity
  for (const LogView* ev = in.next(); ev != nullptr; ev = in.next()) {
    if (ev->channel != channel) continue;
    if (m.decode(ev->data, 0, static_cast<int>(ev->size)) != static_cast<int>(ev->size))
      continue;  // a damaged record: counted as missing below
    Journal& j = out[m.instance];
    auto [seq, first] = next_seq.emplace(m.instance, m.header.seq);
    const int64_t lost = first ? m.header.seq : m.header.seq - seq->second;  // records 0.. were before this one
    if (lost < 0) continue;                                                  // a record seen twice
    // One lost record is the repeat at the front of this one; more are a gap.
    const bool recover = lost >= 1 && m.n_repeat > 0;
    j.recovered_records += recover ? 1 : 0;
    j.missing_records += recover ? lost - 1 : lost;
    seq->second = m.header.seq + 1;
    ++j.records;
    for (int32_t i = recover ? 0 : std::clamp(m.n_repeat, 0, m.n); i < m.n; ++i) {
      if (m.name[i] < 0 || m.name[i] >= m.n_names) continue;
      j.entries.push_back({m.kind[i] == 1, m.names[m.name[i]], m.key[i], m.utime[i]});
    }
  }
  return out;
}

}  // namespace harvest::rt
