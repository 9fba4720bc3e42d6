#include "logtools/export.hpp"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <stdexcept>
#include <unordered_map>

#include "logtools/reflect.hpp"
#include "runtime/json.hpp"

namespace harvest::logtools {
namespace {

bool keep(const std::string& path, const ExportOptions& o) {
  if (o.fields.empty()) return true;
  const std::string g = generic_path(path);
  for (const auto& f : o.fields) {
    const std::string k = generic_path(f);
    if (g == k || path == f) return true;
    if (g.size() > k.size() && g.compare(0, k.size(), k) == 0 && (g[k.size()] == '.' || g[k.size()] == '['))
      return true;
  }
  return false;
}

std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// Numbers as the text form prints them (a float to its 9 digits, not to the
// 17 of the double it is held in).
rt::Json json_value(const Field& f) {
  switch (f.kind) {
    case FieldKind::kInt:
      return f.i;
    case FieldKind::kBool:
      return f.i != 0;
    case FieldKind::kFloat:
    case FieldKind::kDouble:
      return std::isfinite(f.d) ? rt::Json(std::stod(value_text(f))) : rt::Json(nullptr);
    case FieldKind::kString:
    case FieldKind::kBytes:
      return value_text(f);
  }
  return nullptr;
}

}  // namespace

int64_t export_channel(const std::vector<rt::LogRecord>& log, const std::string& channel, const ExportOptions& options,
                       std::ostream& out) {
  struct Row {
    int64_t t;
    Decoded d;
  };
  std::vector<Row> rows;
  for (const auto& r : log)
    if (r.channel == channel) rows.push_back({r.timestamp, decode_any(r.data.data(), r.data.size())});
  if (rows.empty()) throw std::runtime_error("channel '" + channel + "' is not in the log");
  if (options.problems != nullptr)
    for (const auto& row : rows)
      if (row.d.type == nullptr)
        *options.problems << "harvest-log: " << channel << " event at log time " << row.t
                          << " not decoded: " << row.d.error << "\n";

  if (options.format == ExportFormat::kJsonl) {
    for (const auto& row : rows) {
      rt::Json j;
      j["log_utime"] = row.t;
      if (row.d.type == nullptr) {
        j["error"] = row.d.error;
      } else {
        for (const auto& f : row.d.fields.items())
          if (keep(f.path, options)) j[f.path] = json_value(f);
      }
      out << rt::json_line(j) << "\n";
    }
    return static_cast<int64_t>(rows.size());
  }

  // CSV: the union of field paths, in order of first appearance.
  std::vector<std::string> columns;
  std::unordered_map<std::string, std::size_t> index;
  for (const auto& row : rows)
    for (const auto& f : row.d.fields.items())
      if (keep(f.path, options) && index.emplace(f.path, columns.size()).second) columns.push_back(f.path);
  out << "log_utime";
  for (const auto& c : columns) out << "," << csv_cell(c);
  out << "\n";
  std::vector<std::string> cells(columns.size());
  for (const auto& row : rows) {
    std::fill(cells.begin(), cells.end(), std::string());
    for (const auto& f : row.d.fields.items()) {
      auto it = index.find(f.path);
      if (it != index.end()) cells[it->second] = value_text(f);
    }
    out << row.t;
    for (const auto& c : cells) out << "," << csv_cell(c);
    out << "\n";
  }
  return static_cast<int64_t>(rows.size());
}

}  // namespace harvest::logtools
