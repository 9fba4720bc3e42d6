#include "runtime/json.hpp"

#include <cstdio>

namespace harvest::rt {

std::string json_escape(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out;
}

std::string json_quoted(const std::string& s) {
  // Appends, not "\"" + ...: GCC 12 warns falsely (-Wrestrict) on literal + std::string.
  std::string out(1, '"');
  out += json_escape(s);
  out += '"';
  return out;
}

}  // namespace harvest::rt
