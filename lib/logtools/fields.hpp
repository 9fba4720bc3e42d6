// A decoded LCM message as a flat list of (field path, value), e.g.
// "header.utime", "fruits[2].u_px". Built by the generated flatten()
// functions (gen_reflect.py) from the lcm-gen C++ classes, so the replay
// comparison and the log export work for every harvest type without
// per-type code.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace harvest::logtools {

enum class FieldKind { kInt, kFloat, kDouble, kBool, kString, kBytes };

struct Field {
  std::string path;
  FieldKind kind = FieldKind::kInt;
  int64_t i = 0;  // kInt, kBool (0/1)
  double d = 0;   // kFloat, kDouble
  std::string s;  // kString, kBytes (raw bytes)
};

class Fields {
 public:
  void add_int(std::string path, int64_t v);
  void add_float(std::string path, float v);
  void add_double(std::string path, double v);
  void add_bool(std::string path, bool v);
  void add_string(std::string path, const std::string& v);
  void add_bytes(std::string path, const uint8_t* data, std::size_t n);

  const std::vector<Field>& items() const { return items_; }
  const Field* find(const std::string& path) const;

 private:
  std::vector<Field> items_;
};

// "fruits[12].u_px" -> "fruits[].u_px" (the key used for tolerances).
std::string generic_path(const std::string& path);

// The value as text: integers exactly, floats with enough digits to
// round-trip, strings as they are, bytes as "<N bytes>".
std::string value_text(const Field& f);

}  // namespace harvest::logtools
