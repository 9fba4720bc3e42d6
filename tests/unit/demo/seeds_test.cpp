// harvest-demo --seeds: the seed list of a tree benchmark.
#include <gtest/gtest.h>

#include <stdexcept>

#include "demo/demo_driver.hpp"

namespace harvest::demo {
namespace {

TEST(DemoSeeds, RangesAndSingleSeedsInTheOrderGiven) {
  EXPECT_EQ(parse_seed_list("1-4"), (std::vector<uint64_t>{1, 2, 3, 4}));
  EXPECT_EQ(parse_seed_list("404"), (std::vector<uint64_t>{404}));
  EXPECT_EQ(parse_seed_list("9,3,11-12"), (std::vector<uint64_t>{9, 3, 11, 12}));
  EXPECT_EQ(parse_seed_list("0-0"), (std::vector<uint64_t>{0}));
}

TEST(DemoSeeds, BadListsSayWhatIsWrong) {
  auto message = [](const std::string& text) {
    try {
      parse_seed_list(text);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("").find("is not a seed"), std::string::npos);
  EXPECT_NE(message("1,,2").find("'' in '1,,2' is not a seed"), std::string::npos);
  EXPECT_NE(message("a-3").find("'a' in 'a-3'"), std::string::npos);
  EXPECT_NE(message("-3").find("is not a seed"), std::string::npos);
  EXPECT_NE(message("5-2").find("a range goes up"), std::string::npos);
  EXPECT_NE(message("1-5000").find("more than 1000 seeds"), std::string::npos);
  EXPECT_NE(message("99999999999999999999").find("is not a seed"), std::string::npos);
}

}  // namespace
}  // namespace harvest::demo
