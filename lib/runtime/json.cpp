#include "runtime/json.hpp"

#include <cmath>

namespace harvest::rt {

Json json_number(double v, int decimals) {
  if (!std::isfinite(v)) return nullptr;
  const double scale = std::pow(10.0, decimals);
  const double r = std::round(v * scale) / scale;
  return r == 0.0 ? 0.0 : r;  // no "-0.0"
}

std::string json_line(const Json& j) { return j.dump(-1, ' ', false, Json::error_handler_t::replace); }

std::string json_pretty(const Json& j) { return j.dump(2, ' ', false, Json::error_handler_t::replace); }

}  // namespace harvest::rt
