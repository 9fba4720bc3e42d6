#include "demo/progress.hpp"

#include <gtest/gtest.h>

namespace harvest::demo {
namespace {

harvest_status_t status(const std::string& state, int fruit, int picked, int remaining) {
  harvest_status_t s{};
  s.state = state;
  s.current_fruit_id = fruit;
  s.picked = picked;
  s.remaining = remaining;
  return s;
}

TEST(DemoProgress, OneLinePerChangeNotPerMessage) {
  Progress p(2);
  EXPECT_FALSE(p.controller_seen());
  auto line = p.on_status(status("IDLE", -1, 0, 3), 1.0);
  ASSERT_TRUE(line);
  EXPECT_NE(line->find("run 2"), std::string::npos) << *line;
  EXPECT_FALSE(p.started());
  EXPECT_FALSE(p.on_status(status("IDLE", -1, 0, 3), 2.0));
  // The fixed camera's count flickers: no new line for that alone.
  EXPECT_FALSE(p.on_status(status("IDLE", -1, 0, 4), 3.0));
  line = p.on_status(status("APPROACH", 7, 0, 2), 4.0);
  ASSERT_TRUE(line);
  EXPECT_TRUE(p.started());
  EXPECT_NE(line->find("APPROACH"), std::string::npos) << *line;
  EXPECT_NE(line->find("fruit 7"), std::string::npos) << *line;
  EXPECT_NE(line->find("remaining 2"), std::string::npos) << *line;
  line = p.on_status(status("APPROACH", 7, 1, 2), 5.0);
  ASSERT_TRUE(line);
  EXPECT_NE(line->find("picked 1"), std::string::npos) << *line;
}

TEST(DemoProgress, CountsFruitStillOnTheTreeFromTheTruth) {
  Progress p(0);
  sim_truth_t t{};
  t.num_fruits = 3;
  t.fruits.resize(3);
  t.fruits[0].state = sim_fruit_truth_t::ON_TREE;
  t.fruits[1].state = sim_fruit_truth_t::PICKED;
  t.fruits[2].state = sim_fruit_truth_t::ON_TREE;
  EXPECT_EQ(p.on_tree(), -1);
  p.on_truth(t);
  EXPECT_EQ(p.on_tree(), 2);
  const auto line = p.on_status(status("SELECT", -1, 1, 1), 0.5);
  ASSERT_TRUE(line);
  EXPECT_NE(line->find("2 on the tree"), std::string::npos) << *line;
}

}  // namespace
}  // namespace harvest::demo
