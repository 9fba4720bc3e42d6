#include "console/console_state.hpp"

#include <cmath>

namespace harvest::console {

using nlohmann::json;

namespace {
std::string name_of(int8_t v, std::initializer_list<const char*> names) {
  if (v >= 0 && static_cast<std::size_t>(v) < names.size()) return *(names.begin() + v);
  return "UNKNOWN(" + std::to_string(v) + ")";
}
double age_s(int64_t at_us, int64_t now_us) { return static_cast<double>(now_us - at_us) / 1e6; }
double norm3(const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }
}  // namespace

std::string process_state_name(int8_t s) { return name_of(s, {"STARTING", "OK", "DEGRADED", "ERROR", "STOPPING"}); }
std::string robot_mode_name(int8_t m) {
  return name_of(m, {"DISABLED", "ENABLING", "IDLE", "MOVING", "STOPPING", "FAULT", "ESTOP"});
}
std::string ir_validity_name(int8_t v) { return name_of(v, {"VALID", "TOO_NEAR", "TOO_FAR", "NO_DATA"}); }
std::string gripper_state_name(int8_t s) {
  return name_of(s, {"UNKNOWN", "OPEN", "CLOSING", "CLOSED", "HOLDING", "OPENING", "FAULT", "DISCONNECTED"});
}

void ConsoleState::on_process_status(const process_status_t& m, int64_t now_us) {
  processes_[{m.host, m.instance}] = {json{{"host", m.host},
                                           {"instance", m.instance},
                                           {"process", m.process},
                                           {"pid", m.pid},
                                           {"state", process_state_name(m.state)},
                                           {"message", m.message},
                                           {"uptime_s", static_cast<double>(m.uptime_us) / 1e6},
                                           {"received", m.messages_received},
                                           {"published", m.messages_published},
                                           {"decode_errors", m.decode_errors}},
                                      now_us};
}

void ConsoleState::on_harvest_status(const harvest_status_t& m, int64_t now_us) {
  harvest_ = Seen{json{{"state", m.state},
                       {"paused", m.paused != 0},
                       {"estop", m.estop != 0},
                       {"current_fruit_id", m.current_fruit_id},
                       {"picked", m.picked},
                       {"lost", m.lost},
                       {"unreachable", m.unreachable},
                       {"failed_grasp", m.failed_grasp},
                       {"remaining", m.remaining},
                       {"summary", m.summary}},
                  now_us};
}

void ConsoleState::on_robot_state(const robot_state_t& m, int64_t now_us) {
  const auto& p = m.tool_pose;
  robot_ = Seen{json{{"mode", robot_mode_name(m.mode)},
                     {"tool_position", {p.position[0], p.position[1], p.position[2]}},
                     {"tool_orientation", {p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]}},
                     {"speed_mps", norm3(m.tool_twist.linear)},
                     {"angular_speed_rps", norm3(m.tool_twist.angular)},
                     {"joints", m.joint_position},
                     {"command_stale", m.command_stale != 0},
                     {"fault_text", m.fault_text}},
                now_us};
}

void ConsoleState::on_ir_range(const ir_range_t& m, int64_t now_us) {
  ir_ = Seen{json{{"range_m", m.range_m}, {"validity", ir_validity_name(m.validity)}, {"raw", m.raw}}, now_us};
}

void ConsoleState::on_gripper_state(const gripper_state_t& m, int64_t now_us) {
  gripper_ = Seen{json{{"state", gripper_state_name(m.state)},
                       {"position", m.position},
                       {"force_n", m.force_n},
                       {"connected", m.connected != 0},
                       {"fault_text", m.fault_text}},
                  now_us};
}

void ConsoleState::on_detections(const std::string& camera, const fruit_detections_t& m, int64_t now_us) {
  json fruits = json::array();
  for (const auto& f : m.fruits)
    fruits.push_back({{"id", f.id},
                      {"bbox", {f.bbox_px[0], f.bbox_px[1], f.bbox_px[2], f.bbox_px[3]}},
                      {"u", f.u_px},
                      {"v", f.v_px},
                      {"confidence", f.confidence},
                      {"selected", f.selected != 0}});
  detections_[camera] = {json{{"image_width", m.image_width},
                              {"image_height", m.image_height},
                              {"status", m.status_text},
                              {"selected_index", m.selected_index},
                              {"fruits", std::move(fruits)}},
                         now_us};
}

void ConsoleState::on_frame(const std::string& camera, const image_t& m, int64_t now_us) {
  frames_[camera] = {json{{"seq", m.header.seq},
                          {"width", m.width},
                          {"height", m.height},
                          {"roi", {m.roi_px[0], m.roi_px[1], m.roi_px[2], m.roi_px[3]}},
                          {"sensor_width", m.sensor_width},
                          {"sensor_height", m.sensor_height}},
                     now_us};
}

json ConsoleState::to_json(int64_t now_us) const {
  const auto with_age = [&](const std::optional<Seen>& s) -> json {
    if (!s) return nullptr;
    json j = s->data;
    j["age_s"] = age_s(s->at_us, now_us);
    return j;
  };
  json procs = json::array();
  for (const auto& [key, s] : processes_) {
    json j = s.data;
    j["age_s"] = age_s(s.at_us, now_us);
    j["silent"] = now_us - s.at_us > kSilentAfterUs;
    procs.push_back(std::move(j));
  }
  json cameras = json::object();
  for (const auto& [name, s] : frames_) cameras[name]["frame"] = with_age(s);
  for (const auto& [name, s] : detections_) cameras[name]["detections"] = with_age(s);
  return json{{"processes", std::move(procs)}, {"harvest", with_age(harvest_)}, {"robot", with_age(robot_)},
              {"ir", with_age(ir_)},           {"gripper", with_age(gripper_)}, {"cameras", std::move(cameras)}};
}

}  // namespace harvest::console
