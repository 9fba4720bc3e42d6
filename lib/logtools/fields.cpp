#include "logtools/fields.hpp"

#include <cstdio>

namespace harvest::logtools {

void Fields::add_int(std::string path, int64_t v) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kInt;
  f.i = v;
  items_.push_back(std::move(f));
}

void Fields::add_float(std::string path, float v) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kFloat;
  f.d = static_cast<double>(v);
  items_.push_back(std::move(f));
}

void Fields::add_double(std::string path, double v) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kDouble;
  f.d = v;
  items_.push_back(std::move(f));
}

void Fields::add_bool(std::string path, bool v) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kBool;
  f.i = v ? 1 : 0;
  items_.push_back(std::move(f));
}

void Fields::add_string(std::string path, const std::string& v) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kString;
  f.s = v;
  items_.push_back(std::move(f));
}

void Fields::add_bytes(std::string path, const uint8_t* data, std::size_t n) {
  Field f;
  f.path = std::move(path);
  f.kind = FieldKind::kBytes;
  if (n > 0) f.s.assign(reinterpret_cast<const char*>(data), n);
  items_.push_back(std::move(f));
}

const Field* Fields::find(const std::string& path) const {
  for (const auto& f : items_)
    if (f.path == path) return &f;
  return nullptr;
}

std::string generic_path(const std::string& path) {
  std::string out;
  out.reserve(path.size());
  bool in_index = false;
  for (char c : path) {
    if (c == '[') {
      in_index = true;
      out.push_back('[');
      out.push_back(']');
    } else if (c == ']') {
      in_index = false;
    } else if (!in_index) {
      out += c;
    }
  }
  return out;
}

std::string value_text(const Field& f) {
  char buf[64];
  switch (f.kind) {
    case FieldKind::kInt:
      return std::to_string(f.i);
    case FieldKind::kBool:
      return f.i ? "true" : "false";
    case FieldKind::kFloat:
      std::snprintf(buf, sizeof buf, "%.9g", f.d);
      return buf;
    case FieldKind::kDouble:
      std::snprintf(buf, sizeof buf, "%.17g", f.d);
      return buf;
    case FieldKind::kString:
      return f.s;
    case FieldKind::kBytes: {
      std::snprintf(buf, sizeof buf, "<%zu bytes>", f.s.size());
      return buf;
    }
  }
  return {};
}

}  // namespace harvest::logtools
