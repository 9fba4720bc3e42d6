// JSON string escaping for the tools that print JSON lines (harvest-log
// export, harvest-detect).
#pragma once

#include <string>

namespace harvest::rt {

// The characters of `s` escaped for use inside a JSON string (no quotes added).
std::string json_escape(const std::string& s);

// `s` as a quoted JSON string.
std::string json_quoted(const std::string& s);

}  // namespace harvest::rt
