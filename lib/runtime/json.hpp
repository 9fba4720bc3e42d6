// JSON for the tools that print it (harvest-log export, harvest-detect, the
// demo's summary.json): nlohmann-json, keys in the order they were set.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace harvest::rt {

using Json = nlohmann::ordered_json;

// `v` rounded to `decimals` places (a figure for people, not the noise of its
// last bits); null when it is not finite, which JSON cannot write.
Json json_number(double v, int decimals);

// One line. Text that is not UTF-8 (a string field of a message) is written
// with U+FFFD in place of the bad bytes: the line stays valid JSON.
std::string json_line(const Json& j);

// Indented by two spaces, for files people read; same replacement.
std::string json_pretty(const Json& j);

}  // namespace harvest::rt
