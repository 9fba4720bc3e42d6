#include "logtools/reflect.hpp"

#include <algorithm>
#include <cstdio>

#include "logtools/reflect_gen.hpp"
#include "runtime/wire_check.hpp"

namespace harvest::logtools {
namespace {

struct Registry {
  std::vector<TypeInfo> types;
  template <class T>
  void add(const char* name) {
    TypeInfo t;
    t.name = name;
    t.hash = T::getHash();
    t.flatten = [](const void* data, std::size_t size, Fields& out, std::string* why) {
      T msg;
      std::string error = rt::decode_checked(data, size, msg);
      if (!error.empty()) {
        if (why != nullptr) *why = std::move(error);
        return false;
      }
      gen::flatten(msg, "", out);
      return true;
    };
    types.push_back(std::move(t));
  }
};

const Registry& registry() {
  static const Registry r = [] {
    Registry reg;
    gen::register_types(reg);
    std::sort(reg.types.begin(), reg.types.end(), [](const TypeInfo& a, const TypeInfo& b) { return a.name < b.name; });
    return reg;
  }();
  return r;
}

}  // namespace

const std::vector<TypeInfo>& known_types() { return registry().types; }

const TypeInfo* type_by_hash(int64_t hash) {
  for (const auto& t : known_types())
    if (t.hash == hash) return &t;
  return nullptr;
}

const TypeInfo* type_by_name(const std::string& name) {
  for (const auto& t : known_types())
    if (t.name == name || t.name.substr(t.name.find('.') + 1) == name) return &t;
  return nullptr;
}

std::optional<int64_t> fingerprint(const void* data, std::size_t size) {
  if (size < 8) return std::nullopt;
  const auto* b = static_cast<const uint8_t*>(data);
  uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | b[i];
  return static_cast<int64_t>(h);
}

std::string hex_fingerprint(int64_t hash) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(hash));
  return buf;
}

Decoded decode_any(const void* data, std::size_t size) {
  Decoded d;
  auto fp = fingerprint(data, size);
  if (!fp) {
    d.error = "shorter than a fingerprint (" + std::to_string(size) + " bytes)";
    return d;
  }
  const TypeInfo* t = type_by_hash(*fp);
  if (t == nullptr) {
    d.error = "unknown type, fingerprint " + hex_fingerprint(*fp);
    return d;
  }
  std::string why;
  if (!t->flatten(data, size, d.fields, &why)) {
    d.error = "malformed " + t->name + " (" + std::to_string(size) + " bytes): " + why;
    d.fields = {};
    return d;
  }
  d.type = t;
  return d;
}

}  // namespace harvest::logtools
