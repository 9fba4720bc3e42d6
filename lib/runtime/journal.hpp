// A process's journal (JOURNAL, harvest.node_journal_t): every message its
// nodes handled and every timer that fired, in order, with the now() each
// saw. Live, handler and callback times are the wall clock at that moment and
// inputs reach a node in its own socket's order, neither of which the
// recording holds; the journal does. A replay driven by it (JournalRunner)
// gives a node exactly its live inputs at its live times, so a timer-driven
// node (the servo controller) regenerates what it published, not an
// approximation (docs/replay.md "Journals").
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "harvest/node_journal_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/clock.hpp"

namespace harvest::rt {

inline constexpr const char* kJournalChannel = channels::kJournal;

// Names one message among those on its channel: its size and first 256 bytes
// (the header, with utime and seq, comes first in every message), so hashing
// a camera image costs nothing. FNV-1a.
int64_t journal_key(const void* data, std::size_t size);

struct JournalEntry {
  bool timer = false;
  std::string name;  // logical channel, or timer label "node#k"
  int64_t key = 0;
  Micros utime = 0;
};

// Collects entries live; a record is due every 64 entries or 100 ms.
class JournalWriter {
 public:
  explicit JournalWriter(std::string instance) : instance_(std::move(instance)) {}
  void message(const std::string& channel, const void* data, std::size_t size, Micros t);
  void timer(const std::string& label, Micros t);
  bool due(Micros now) const { return !entries_.empty() && (entries_.size() >= 64 || now - first_ >= 100'000); }
  bool empty() const { return entries_.empty(); }
  // The record of everything since the last one (entries cleared).
  node_journal_t take(Micros now);

 private:
  // An entry names its channel or timer by an index into names_: no string
  // copied per message handled.
  struct Entry {
    bool timer;
    int32_t name;
    int64_t key;
    Micros utime;
  };
  int32_t name_id(const std::string& name);

  std::string instance_;
  std::vector<std::string> names_;
  std::unordered_map<std::string, int32_t> ids_;
  std::vector<Entry> entries_;
  std::vector<Entry> previous_;  // repeated in the next record
  Micros first_ = 0;
  int64_t seq_ = 0;
};

// Every entry of each instance's journal records in a log, in order (records
// are published in order and carry their seq; a record the logger lost is
// taken from the repeat in the next one, `recovered_records`; two in a row
// are a gap, `missing_records`).
struct Journal {
  std::vector<JournalEntry> entries;
  int64_t records = 0;
  int64_t missing_records = 0;
  int64_t recovered_records = 0;
};
std::map<std::string, Journal> read_journals(const std::string& log_path, const std::string& prefix);

}  // namespace harvest::rt
