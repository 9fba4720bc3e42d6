// Typed, validated access to YAML configuration.
//
// A Document owns a YAML tree loaded from a file. Components read it through
// Node views: every read names the key, the expected type and (for numbers)
// the valid range, and failures throw config::Error naming the file, the full
// key path and what was expected. Defaults are written back into the tree, so
// the tree emitted after loading is the *effective* configuration. After the
// typed structs are built, Document::check_unused() reports keys nobody read
// (typos, stale options) as errors.
#pragma once

#include <yaml-cpp/yaml.h>

#include "config/key.hpp"

#include <filesystem>
#include <limits>
#include <array>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace harvest::config {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {
struct Shared {
  std::string file;                 // file the tree came from ("<string>" for text)
  std::set<std::string> used;       // full key paths that were read
};
std::string describe(const YAML::Node& n);
}  // namespace detail

class Node {
 public:
  Node(YAML::Node node, std::string path, std::shared_ptr<detail::Shared> shared);

  const std::string& path() const { return path_; }
  const std::string& file() const { return shared_->file; }
  bool has(const std::string& key) const;

  // Required value; throws if missing or of the wrong type.
  template <class T>
  T required(const std::string& key, Range<T> range = {}) const;

  // Optional value with a default (recorded into the effective configuration).
  template <class T>
  T get(const std::string& key, const T& fallback, Range<T> range = {}) const;

  // Declared keys (the usual way): name, default and range from the declaration.
  template <class T>
  typename KeyTraits<T>::Value get(const Key<T>& key) const;
  // A key whose default is derived from other values (key.derived says how).
  template <class T>
  T get(const Key<T>& key, const T& derived_fallback) const {
    static_assert(!std::is_same_v<T, Path>);
    if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, bool>) return get<T>(key.name, derived_fallback);
    else return get<T>(key.name, derived_fallback, key.range);
  }
  std::string get(const Choice& key) const;
  std::vector<double> get(const Numbers& key) const;
  // A list whose default is derived from other values (key.derived says how).
  std::vector<double> get(const Numbers& key, const std::vector<double>& derived_fallback) const;
  // A required list whose length is known only at run time (one per joint).
  std::vector<double> get(const Numbers& key, std::size_t size) const { return numbers(key.name, size); }

  // A string that must be one of `choices`.
  std::string choice(const std::string& key, const std::string& fallback,
                     const std::vector<std::string>& choices) const;

  // A fixed-size or free-size numeric list.
  std::vector<double> numbers(const std::string& key, std::size_t expected_size = 0) const;
  std::vector<double> numbers(const std::string& key, const std::vector<double>& fallback,
                              std::size_t expected_size = 0) const;

  // A path; relative paths are resolved against the directory of the file.
  std::filesystem::path file_path(const std::string& key) const;
  std::filesystem::path file_path(const std::string& key, const std::string& fallback) const;

  // Nested mapping; a missing optional child is created empty so defaults land in it.
  Node child(const std::string& key) const;
  Node required_child(const std::string& key) const;
  // Elements of a sequence of mappings.
  std::vector<Node> children(const std::string& key) const;
  // Keys of a mapping child, in file order.
  std::vector<std::string> keys() const;

  [[noreturn]] void fail(const std::string& key, const std::string& expected) const;
  std::string key_path(const std::string& key) const;
  const YAML::Node& yaml() const { return node_; }

 private:
  YAML::Node lookup(const std::string& key) const;
  YAML::Node node_;
  std::string path_;
  std::shared_ptr<detail::Shared> shared_;
};

class Document {
 public:
  static Document load_file(const std::filesystem::path& file);
  static Document load_string(const std::string& text, const std::string& name = "<string>");

  Node root() const;
  // Apply "a.b.c=value" overrides (value parsed as YAML). Throws on bad
  // syntax, an empty key, or a path deeper than kMaxOverrideDepth.
  void apply_override(const std::string& assignment);
  static constexpr std::size_t kMaxOverrideDepth = 16;
  // Throws Error listing every key that was never read.
  void check_unused() const;
  // The effective configuration (after overrides and defaults) as YAML text.
  std::string emit() const;
  const std::string& file() const { return shared_->file; }

 private:
  YAML::Node tree_;
  std::shared_ptr<detail::Shared> shared_;
};

// ---- template implementations ----
namespace detail {
template <class T>
const char* type_name() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean (true/false)";
  else if constexpr (std::is_integral_v<T>) return "an integer";
  else if constexpr (std::is_floating_point_v<T>) return "a number";
  else if constexpr (std::is_same_v<T, std::string>) return "a string";
  else return "a value";
}
template <class T>
std::string range_text(const Range<T>& r) {
  if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
    const bool lo = r.min != std::numeric_limits<T>::lowest();
    const bool hi = r.max != std::numeric_limits<T>::max();
    if (lo && hi) return " in [" + std::to_string(r.min) + ", " + std::to_string(r.max) + "]";
    if (lo) return " >= " + std::to_string(r.min);
    if (hi) return " <= " + std::to_string(r.max);
  }
  return "";
}
}  // namespace detail

template <class T>
T Node::required(const std::string& key, Range<T> range) const {
  YAML::Node v = lookup(key);
  if (!v || v.IsNull()) fail(key, std::string("a required value: ") + detail::type_name<T>() + detail::range_text(range));
  T out{};
  if (!v.IsScalar()) fail(key, std::string(detail::type_name<T>()) + ", got " + detail::describe(v));
  try {
    out = v.as<T>();
  } catch (const YAML::Exception&) {
    fail(key, std::string(detail::type_name<T>()) + ", got '" + v.Scalar() + "'");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!(out == out)) fail(key, "a finite number, got NaN");
  }
  if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
    if (out < range.min || out > range.max)
      fail(key, std::string(detail::type_name<T>()) + detail::range_text(range) + ", got " + v.Scalar());
  }
  return out;
}

template <class T>
T Node::get(const std::string& key, const T& fallback, Range<T> range) const {
  if (!has(key)) {
    YAML::Node n = node_;
    n[key] = fallback;
    shared_->used.insert(key_path(key));
    return fallback;
  }
  return required<T>(key, range);
}

template <class T>
typename KeyTraits<T>::Value Node::get(const Key<T>& key) const {
  if constexpr (std::is_same_v<T, Path>) {
    return key.required ? file_path(key.name) : file_path(key.name, std::string(key.fallback));
  } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, bool>) {
    return key.required ? required<T>(key.name) : get<T>(key.name, T(key.fallback));
  } else {
    return key.required ? required<T>(key.name, key.range) : get<T>(key.name, key.fallback, key.range);
  }
}

}  // namespace harvest::config
