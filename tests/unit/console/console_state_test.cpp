#include "console/console_state.hpp"

#include <gtest/gtest.h>

namespace harvest::console {
namespace {

process_status_t proc(const std::string& host, const std::string& instance, int8_t state) {
  process_status_t p{};
  p.host = host;
  p.instance = instance;
  p.process = "harvest-" + instance;
  p.pid = 42;
  p.state = state;
  p.message = "fine";
  p.uptime_us = 2'500'000;
  return p;
}

TEST(ConsoleState, EmptyBeforeAnyMessage) {
  ConsoleState s;
  const auto j = s.to_json(0);
  EXPECT_TRUE(j["processes"].empty());
  EXPECT_TRUE(j["harvest"].is_null());
  EXPECT_TRUE(j["robot"].is_null());
  EXPECT_TRUE(j["ir"].is_null());
  EXPECT_TRUE(j["gripper"].is_null());
  EXPECT_TRUE(j["cameras"].empty());
}

TEST(ConsoleState, EveryProcessOnEveryHostAndSilentOnesMarked) {
  ConsoleState s;
  s.on_process_status(proc("robot-pc", "robot-link", process_status_t::STATE_OK), 0);
  s.on_process_status(proc("vision-pc", "detector-fixed", process_status_t::STATE_DEGRADED), 1'000'000);
  // Same instance name on another host is another process.
  s.on_process_status(proc("vision-pc", "robot-link", process_status_t::STATE_ERROR), 1'000'000);
  // A newer status replaces the older one of the same process.
  s.on_process_status(proc("robot-pc", "robot-link", process_status_t::STATE_OK), 500'000);
  auto j = s.to_json(3'600'000);
  ASSERT_EQ(j["processes"].size(), 3u);
  EXPECT_EQ(j["processes"][0]["host"], "robot-pc");
  EXPECT_EQ(j["processes"][0]["state"], "OK");
  EXPECT_EQ(j["processes"][0]["silent"], true);  // 3.1 s since it was heard
  EXPECT_DOUBLE_EQ(j["processes"][0]["age_s"].get<double>(), 3.1);
  EXPECT_DOUBLE_EQ(j["processes"][0]["uptime_s"].get<double>(), 2.5);
  EXPECT_EQ(j["processes"][1]["instance"], "detector-fixed");
  EXPECT_EQ(j["processes"][1]["state"], "DEGRADED");
  EXPECT_EQ(j["processes"][1]["silent"], false);
  EXPECT_EQ(j["processes"][2]["state"], "ERROR");
}

TEST(ConsoleState, HarvestTalliesAndArmSpeed) {
  ConsoleState s;
  harvest_status_t h{};
  h.state = "APPROACH";
  h.picked = 2;
  h.lost = 1;
  h.remaining = 4;
  h.estop = true;
  h.summary = "APPROACH fruit 3";
  s.on_harvest_status(h, 0);
  robot_state_t r{};
  r.mode = robot_state_t::MODE_MOVING;
  r.num_joints = 2;
  r.joint_position = {0.1, 0.2};
  r.tool_pose.position[0] = 0.5;
  r.tool_twist.linear[0] = 0.03;
  r.tool_twist.linear[1] = 0.04;
  s.on_robot_state(r, 0);
  const auto j = s.to_json(250'000);
  EXPECT_EQ(j["harvest"]["state"], "APPROACH");
  EXPECT_EQ(j["harvest"]["picked"], 2);
  EXPECT_EQ(j["harvest"]["lost"], 1);
  EXPECT_EQ(j["harvest"]["remaining"], 4);
  EXPECT_EQ(j["harvest"]["estop"], true);
  EXPECT_DOUBLE_EQ(j["harvest"]["age_s"].get<double>(), 0.25);
  EXPECT_EQ(j["robot"]["mode"], "MOVING");
  EXPECT_NEAR(j["robot"]["speed_mps"].get<double>(), 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(j["robot"]["tool_position"][0].get<double>(), 0.5);
  EXPECT_EQ(j["robot"]["joints"].size(), 2u);
}

TEST(ConsoleState, IrGripperAndUnknownEnumValues) {
  ConsoleState s;
  ir_range_t ir{};
  ir.validity = ir_range_t::TOO_NEAR;
  ir.range_m = 0.03f;
  s.on_ir_range(ir, 0);
  gripper_state_t g{};
  g.state = gripper_state_t::STATE_HOLDING;
  g.connected = true;
  s.on_gripper_state(g, 0);
  const auto j = s.to_json(0);
  EXPECT_EQ(j["ir"]["validity"], "TOO_NEAR");
  EXPECT_NEAR(j["ir"]["range_m"].get<double>(), 0.03, 1e-6);
  EXPECT_EQ(j["gripper"]["state"], "HOLDING");
  EXPECT_EQ(gripper_state_name(99), "UNKNOWN(99)");
  EXPECT_EQ(robot_mode_name(-1), "UNKNOWN(-1)");
  EXPECT_EQ(robot_mode_name(robot_state_t::MODE_ESTOP), "ESTOP");
  EXPECT_EQ(process_state_name(process_status_t::STATE_STOPPING), "STOPPING");
}

TEST(ConsoleState, CameraFrameAndDetectionsWithTheSelectedTarget) {
  ConsoleState s;
  image_t img{};
  img.header.seq = 17;
  img.width = 320;
  img.height = 240;
  img.roi_px[2] = 640;
  img.roi_px[3] = 480;
  img.sensor_width = 640;
  img.sensor_height = 480;
  s.on_frame("fixed", img, 0);
  fruit_detections_t d{};
  d.camera = "fixed";
  d.selected_index = 1;
  d.num_fruits = 2;
  d.fruits.resize(2);
  d.fruits[0].id = 5;
  d.fruits[1].id = 6;
  d.fruits[1].selected = true;
  d.fruits[1].bbox_px[0] = 10;
  d.fruits[1].bbox_px[3] = 40;
  s.on_detections("fixed", d, 0);
  const auto j = s.to_json(100'000);
  const auto& cam = j["cameras"]["fixed"];
  EXPECT_EQ(cam["frame"]["seq"], 17);
  EXPECT_EQ(cam["frame"]["roi"][2], 640);
  ASSERT_EQ(cam["detections"]["fruits"].size(), 2u);
  EXPECT_EQ(cam["detections"]["selected_index"], 1);
  EXPECT_EQ(cam["detections"]["fruits"][1]["selected"], true);
  EXPECT_EQ(cam["detections"]["fruits"][1]["id"], 6);
  EXPECT_EQ(cam["detections"]["fruits"][1]["bbox"][3], 40);
  EXPECT_FALSE(j["cameras"].contains("hand"));
}

}  // namespace
}  // namespace harvest::console
