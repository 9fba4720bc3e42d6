#include "logtools/replay_tool.hpp"

#include <gtest/gtest.h>

#include <sstream>

namespace lt = harvest::logtools;

TEST(ReplayTool, NodeSpecsNameAProcessAnOptionalLabelAndConfig) {
  auto s = lt::parse_node_spec("fruit-detector:config/vision/detector-fixed.yaml");
  EXPECT_EQ(s.process, "fruit-detector");
  EXPECT_EQ(s.config, "config/vision/detector-fixed.yaml");
  EXPECT_EQ(s.label, "");
  s = lt::parse_node_spec("fixed=fruit-detector");
  EXPECT_EQ(s.label, "fixed");
  EXPECT_EQ(s.process, "fruit-detector");
  EXPECT_EQ(s.config, "");
  try {
    lt::parse_node_spec("robot-link:config/arm/robot_link.yaml");
    FAIL() << "a device node is not replayable";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no replayable node 'robot-link'"), std::string::npos) << e.what();
  }
}

TEST(ReplayTool, ConfigurationProblemsAreRefusedBeforeTheLogIsRead) {
  lt::ReplayToolOptions o;
  o.input_log = "/nonexistent/log.lcmlog";
  o.output_log = "/nonexistent/out.lcmlog";
  std::ostringstream out, err;
  auto run = [&](std::vector<std::string> nodes, std::vector<std::string> sets) {
    o.nodes = std::move(nodes);
    o.overrides = std::move(sets);
    err.str("");
    return lt::run_replay_tool(o, out, err);
  };
  EXPECT_EQ(run({"fruit-detector:config/vision/detector-fixed.yaml", "fruit-detector:config/vision/detector-hand.yaml"},
                {"detector.min_area_px=3"}),
            2);
  EXPECT_NE(err.str().find("several nodes, write --set LABEL:key=value"), std::string::npos) << err.str();
  EXPECT_EQ(run({"fruit-detector:config/vision/detector-fixed.yaml"}, {"hand:detector.min_area_px=3"}), 2);
  EXPECT_NE(err.str().find("no node labelled 'hand' (nodes: fruit-detector)"), std::string::npos) << err.str();
  EXPECT_EQ(run({"reconstructor:config/vision/reconstructor.yaml"}, {"no_such_key=1"}), 2);
  EXPECT_NE(err.str().find("no_such_key"), std::string::npos) << err.str();
  EXPECT_EQ(run({"fruit-detector", "fruit-detector"}, {}), 2);
  EXPECT_NE(err.str().find("two nodes are labelled 'fruit-detector'"), std::string::npos) << err.str();
  // Valid configuration: only now the missing log is an error (3).
  EXPECT_EQ(run({"fruit-detector/detector-fixed=fruit-detector:config/vision/detector-fixed.yaml"},
                {"fruit-detector/detector-fixed:detector.min_area_px=3"}),
            3);
  EXPECT_NE(err.str().find("cannot open log /nonexistent/log.lcmlog"), std::string::npos) << err.str();
}
