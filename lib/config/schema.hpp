// The reference table of every configuration key, built from the key
// declarations (config.hpp: Key, Choice, Numbers). Each component lists its
// declared keys per section (the path of the mapping they live in, e.g.
// robot_link.can) in a schema function; harvest-config-doc prints them all as
// docs/configuration.md, which a test keeps in step with the code.
#pragma once

#include <string>
#include <vector>

#include "config/key.hpp"

namespace harvest::config {

struct KeyInfo {
  std::string name, type, fallback, range, unit, doc;
};

struct Section {
  std::string path;   // mapping the keys live in, from the top of the file
  std::string where;  // which files or processes have it, one line
  std::vector<KeyInfo> keys;
};

namespace detail {
std::string number_text(double v);
std::string number_text(long long v);
// "[lo, hi]", ">= lo", "<= hi" or "" (out of line: GCC 12 warns falsely on
// string concatenation inlined into every schema function).
std::string range_text(const std::string& lo, const std::string& hi);
}  // namespace detail

template <class T>
KeyInfo describe(const Key<T>& k) {
  KeyInfo i{k.name, "", "", "", k.unit, k.doc};
  if constexpr (std::is_same_v<T, bool>) {
    i.type = "bool";
    i.fallback = k.fallback ? "true" : "false";
  } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, Path>) {
    i.type = std::is_same_v<T, Path> ? "path" : "string";
    i.fallback = k.fallback.empty() ? "\"\"" : std::string(k.fallback);
  } else {
    i.type = std::is_integral_v<T> ? "integer" : "number";
    using Wide = std::conditional_t<std::is_integral_v<T>, long long, double>;
    i.fallback = detail::number_text(static_cast<Wide>(k.fallback));
    const bool lo = k.range.min != std::numeric_limits<T>::lowest();
    const bool hi = k.range.max != std::numeric_limits<T>::max();
    i.range = detail::range_text(lo ? detail::number_text(static_cast<Wide>(k.range.min)) : std::string(),
                                 hi ? detail::number_text(static_cast<Wide>(k.range.max)) : std::string());
  }
  if (k.required) i.fallback = "required";
  if (k.derived) i.fallback = k.derived;
  return i;
}
KeyInfo describe(const Choice& k);
KeyInfo describe(const Numbers& k);

template <class... K>
Section section(std::string path, std::string where, const K&... keys) {
  return Section{std::move(path), std::move(where), {describe(keys)...}};
}

// The markdown reference: a heading, then one table per section.
std::string reference_markdown(const std::vector<Section>& sections);

}  // namespace harvest::config
