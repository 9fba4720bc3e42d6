// Any harvest LCM message by fingerprint: its type name and its fields.
// Decoding uses the lcm-gen C++ classes; the per-type flatten code is
// generated from lcmtypes/*.lcm at build time (gen_reflect.py), so new
// message types need no change here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "logtools/fields.hpp"

namespace harvest::logtools {

struct TypeInfo {
  std::string name;  // "harvest.image_t"
  int64_t hash = 0;  // the fingerprint an encoded message starts with
  // Checked decode (rt::decode_checked) then flatten; false with `why` set
  // (if not null) when the bytes are malformed.
  bool (*flatten)(const void* data, std::size_t size, Fields& out, std::string* why) = nullptr;
};

// Every known type, sorted by name.
const std::vector<TypeInfo>& known_types();
const TypeInfo* type_by_hash(int64_t hash);
// "image_t" or "harvest.image_t"
const TypeInfo* type_by_name(const std::string& name);

// The first 8 bytes of an encoded message (big-endian), if there are 8.
std::optional<int64_t> fingerprint(const void* data, std::size_t size);

struct Decoded {
  const TypeInfo* type = nullptr;  // null: unknown fingerprint or malformed
  Fields fields;
  std::string error;  // why type is null
};
Decoded decode_any(const void* data, std::size_t size);

std::string hex_fingerprint(int64_t hash);

}  // namespace harvest::logtools
