// Every harvest type encoded in C++ decodes with the generated Java classes
// (what lcm-spy uses) to the same values, and re-encodes to the same bytes.
#include <gtest/gtest.h>

#include <harvest/config_snapshot_t.hpp>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/feature_matches_t.hpp>
#include <harvest/feature_tracks_t.hpp>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/gripper_command_t.hpp>
#include <harvest/gripper_state_t.hpp>
#include <harvest/harvest_status_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/ir_range_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <harvest/targets_t.hpp>

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace harvest;

namespace {

template <class T>
void save(const ht::TempDir& dir, const char* type, const T& msg) {
  const auto bytes = rt::encode(msg);
  std::ofstream(dir / (std::string(type) + ".bin"), std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

header_t header(int64_t seq) {
  header_t h{};
  h.utime = 1'700'000'000'123'456;
  h.seq = seq;
  h.frame_id = "base";
  h.source_seq = seq - 1;
  h.publish_utime = h.utime + 1500;
  return h;
}

std::string run(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

}  // namespace

TEST(JavaTypes, DecodeWhatCppEncoded) {
  ht::TempDir dir;
  image_t img{};
  img.header = header(1);
  img.encoding = image_t::ENCODING_BGR8;
  img.width = 4;
  img.height = 2;
  img.stride = 12;
  img.sensor_width = 640;
  img.sensor_height = 480;
  img.roi_px[2] = 640;
  img.roi_px[3] = 480;
  img.data.assign(24, 7);
  img.size = 24;
  save(dir, "image_t", img);

  fruit_detections_t det{};
  det.header = header(2);
  det.camera = "fixed";
  det.image_width = 640;
  det.selected_index = 0;
  fruit_t f{};
  f.id = 3;
  f.u_px = 321.5f;
  f.selected = true;
  det.fruits = {f, f};
  det.num_fruits = 2;
  save(dir, "fruit_detections_t", det);

  feature_tracks_t tracks{};
  tracks.header = header(3);
  tracks.features.resize(3);
  tracks.num_features = 3;
  save(dir, "feature_tracks_t", tracks);

  feature_matches_t matches{};
  matches.header = header(4);
  matches.status = feature_matches_t::STATUS_TOO_FEW;
  matches.num_matches = 2;
  matches.desired_u_px = matches.desired_v_px = matches.current_u_px = matches.current_v_px = {1.f, 2.f};
  save(dir, "feature_matches_t", matches);

  targets_t targets{};
  targets.header = header(5);
  targets.selected_fruit_id = 7;
  targets.targets.resize(1);
  targets.targets[0].position_base[1] = 1.0668;
  targets.num_targets = 1;
  save(dir, "targets_t", targets);

  robot_state_t rs{};
  rs.header = header(6);
  rs.mode = robot_state_t::MODE_MOVING;
  rs.num_joints = 7;
  rs.joint_position.assign(7, 0.25);
  rs.joint_velocity.assign(7, 0.0);
  rs.joint_velocity_cmd.assign(7, 0.0);
  rs.drive_state.assign(7, 4);
  rs.drive_error_code.assign(7, 0);
  rs.fault_text = "";
  save(dir, "robot_state_t", rs);

  robot_command_t rc{};
  rc.header = header(7);
  rc.type = robot_command_t::TYPE_TWIST;
  rc.validity_us = 100000;
  rc.twist.linear[0] = 0.381;
  save(dir, "robot_command_t", rc);

  ir_range_t ir{};
  ir.header = header(8);
  ir.raw = 512;
  ir.range_m = 0.125f;
  save(dir, "ir_range_t", ir);

  gripper_command_t gc{};
  gc.header = header(9);
  gc.action = gripper_command_t::ACTION_CLOSE;
  save(dir, "gripper_command_t", gc);

  gripper_state_t gs{};
  gs.header = header(10);
  gs.state = gripper_state_t::STATE_HOLDING;
  gs.connected = true;
  save(dir, "gripper_state_t", gs);

  harvest_status_t hs{};
  hs.header = header(11);
  hs.state = "APPROACH";
  hs.picked = 4;
  hs.outcomes.resize(2);
  hs.num_outcomes = 2;
  save(dir, "harvest_status_t", hs);

  operator_command_t oc{};
  oc.header = header(12);
  oc.command = operator_command_t::HOME;
  oc.source = "test";
  save(dir, "operator_command_t", oc);

  emergency_stop_t es{};
  es.header = header(13);
  es.engaged = true;
  es.reason = "test stop";
  save(dir, "emergency_stop_t", es);

  process_status_t ps{};
  ps.header = header(14);
  ps.process = "harvest-sim";
  ps.counter_names = {"frames", "drops"};
  ps.counter_values = {100, 2};
  ps.num_counters = 2;
  save(dir, "process_status_t", ps);

  config_snapshot_t cs{};
  cs.header = header(15);
  cs.yaml = "gain: 2\n";
  save(dir, "config_snapshot_t", cs);

  const std::string cp = std::string("/usr/share/java/lcm.jar:") + HARVEST_TYPES_JAR + ":" + DECODE_CHECK_JAR;
  const std::string out = run("java -cp " + cp + " DecodeCheck " + dir.path().string() + " 2>&1");
  std::map<std::string, std::string> lines;
  std::istringstream ss(out);
  for (std::string line; std::getline(ss, line);) lines[line.substr(0, line.find(' '))] = line;
  ASSERT_EQ(lines.size(), 15u) << out;
  for (const auto& [type, line] : lines) EXPECT_NE(line.find(type + " OK"), std::string::npos) << line;
  EXPECT_NE(lines["image_t"].find("width=4"), std::string::npos) << lines["image_t"];
  EXPECT_NE(lines["image_t"].find("encoding=0"), std::string::npos);
  EXPECT_NE(lines["fruit_detections_t"].find("camera=fixed"), std::string::npos);
  EXPECT_NE(lines["robot_command_t"].find("validity_us=100000"), std::string::npos);
  EXPECT_NE(lines["ir_range_t"].find("raw=512"), std::string::npos);
  EXPECT_NE(lines["ir_range_t"].find("range_m=0.125"), std::string::npos);
  EXPECT_NE(lines["config_snapshot_t"].find("yaml=gain: 2\\n"), std::string::npos);
  EXPECT_NE(lines["harvest_status_t"].find("state=APPROACH"), std::string::npos);
  EXPECT_NE(lines["emergency_stop_t"].find("reason=test stop"), std::string::npos);
}

TEST(JavaTypes, CorruptBytesAreRejectedByJava) {
  ht::TempDir dir;
  ir_range_t ir{};
  auto bytes = rt::encode(ir);
  bytes[0] ^= 0xff;  // break the fingerprint
  std::ofstream(dir / "ir_range_t.bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const std::string cp = std::string("/usr/share/java/lcm.jar:") + HARVEST_TYPES_JAR + ":" + DECODE_CHECK_JAR;
  const std::string out = run("java -cp " + cp + " DecodeCheck " + dir.path().string() + " 2>&1");
  EXPECT_NE(out.find("ir_range_t FAIL"), std::string::npos) << out;
}
