// Declarations of configuration keys, without the YAML machinery, so the
// headers of typed config structs can take their members' defaults from them:
// `double gain = keys::gain.fallback;`. Read with config::Node::get(key)
// (config.hpp); listed in the reference by config/schema.hpp.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace harvest::config {

template <class T>
struct Range {
  T min = std::numeric_limits<T>::lowest();
  T max = std::numeric_limits<T>::max();
};

// A file path read from configuration; relative paths are resolved against
// the directory of the file (Node::file_path).
struct Path {};
struct NoRange {};

template <class T>
struct KeyTraits {
  using Stored = T;  // the default as written in a constexpr declaration
  using Value = T;   // what Node::get returns
  using RangeType = Range<T>;
};
template <>
struct KeyTraits<bool> {
  using Stored = bool;
  using Value = bool;
  using RangeType = NoRange;
};
template <>
struct KeyTraits<std::string> {
  using Stored = std::string_view;
  using Value = std::string;
  using RangeType = NoRange;
};
template <>
struct KeyTraits<Path> {
  using Stored = std::string_view;
  using Value = std::filesystem::path;
  using RangeType = NoRange;
};

// One scalar key: `constexpr Key<double> kGain{"gain", 5.0, {0.0, 100.0}, "1/s", "what it does"};`
// A required key has no default: `{.name = "port", .doc = "...", .required = true}`.
// A key whose default the loader derives from other values says how in `derived`.
template <class T>
struct Key {
  const char* name;
  typename KeyTraits<T>::Stored fallback{};
  typename KeyTraits<T>::RangeType range{};
  const char* unit = "";
  const char* doc = "";
  bool required = false;
  const char* derived = nullptr;
};

// A string that must be one of a few words (at most 8).
struct Choice {
  const char* name;
  std::string_view fallback;
  std::array<std::string_view, 8> choices{};
  const char* doc = "";
  std::vector<std::string> list() const;
};

// A list of numbers: exactly `size` of them (0: any number). Its default is
// the first `size` values of `fallback` (an empty list when size is 0), unless
// the key is required or the loader supplies a default derived from other
// values, which `derived` then describes.
struct Numbers {
  const char* name;
  std::size_t size = 0;
  std::array<double, 16> fallback{};
  const char* unit = "";
  const char* doc = "";
  bool required = false;
  const char* derived = nullptr;
  std::vector<double> defaults() const;
};

}  // namespace harvest::config
