// rt::json: the one JSON writer of the tools (nlohmann-json underneath).
#include "runtime/json.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rt = harvest::rt;

namespace {

TEST(Json, FiguresAreRoundedAndNonFiniteNumbersAreNull) {
  EXPECT_EQ(rt::json_line({{"a", rt::json_number(0.123456, 3)}, {"b", rt::json_number(2.5, 0)}}),
            "{\"a\":0.123,\"b\":3.0}");
  EXPECT_EQ(rt::json_line({{"z", rt::json_number(-0.0004, 3)}}), "{\"z\":0.0}") << "no -0.0";
  EXPECT_TRUE(rt::json_number(std::nan(""), 2).is_null());
  EXPECT_TRUE(rt::json_number(std::numeric_limits<double>::infinity(), 2).is_null());
}

TEST(Json, KeysKeepTheirOrderAndTextIsEscaped) {
  rt::Json j;
  j["zeta"] = 1;
  j["alpha"] = "quote \" backslash \\ newline \n tab \t escape \x1b";
  EXPECT_EQ(rt::json_line(j),
            "{\"zeta\":1,\"alpha\":\"quote \\\" backslash \\\\ newline \\n tab \\t escape \\u001b\"}");
  EXPECT_EQ(rt::Json::parse(rt::json_line(j)), j);
  EXPECT_EQ(rt::json_pretty({{"a", 1}}), "{\n  \"a\": 1\n}");
}

// A message's string field may hold any bytes but NUL: the line stays JSON.
TEST(Json, BytesThatAreNotUtf8AreReplacedNotThrown) {
  const std::string line = rt::json_line({{"s", std::string("ok \xff\xfe end")}});
  EXPECT_EQ(line, "{\"s\":\"ok \xef\xbf\xbd\xef\xbf\xbd end\"}");
  EXPECT_NO_THROW((void)rt::Json::parse(line));
}

}  // namespace
