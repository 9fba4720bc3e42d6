// What the operator console shows, built from the messages it hears and
// handed to the browser as one JSON document (docs/console.md): every
// process and host with its health, the controller's state and tallies, the
// arm's pose and speed, IR, gripper, and per camera the last frame's size and
// the detections with the selected target.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/image_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/process_status_t.hpp"
#include "harvest/robot_state_t.hpp"

namespace harvest::console {

// A process whose status is older than this is shown as silent [us]
// (processes report once a second).
inline constexpr int64_t kSilentAfterUs = 3'000'000;

class ConsoleState {
 public:
  // Each takes the message and the console's receive time [us].
  void on_process_status(const process_status_t& m, int64_t now_us);
  void on_harvest_status(const harvest_status_t& m, int64_t now_us);
  void on_robot_state(const robot_state_t& m, int64_t now_us);
  void on_ir_range(const ir_range_t& m, int64_t now_us);
  void on_gripper_state(const gripper_state_t& m, int64_t now_us);
  void on_detections(const std::string& camera, const fruit_detections_t& m, int64_t now_us);
  // A frame passed on to the browser (its pixels are served separately).
  void on_frame(const std::string& camera, const image_t& m, int64_t now_us);

  // The page's state at `now_us`; ages in seconds, absent parts null.
  nlohmann::json to_json(int64_t now_us) const;

 private:
  struct Seen {
    nlohmann::json data;
    int64_t at_us = 0;
  };
  std::map<std::pair<std::string, std::string>, Seen> processes_;  // (host, instance)
  std::optional<Seen> harvest_, robot_, ir_, gripper_;
  std::map<std::string, Seen> frames_, detections_;  // by camera name
};

// Names of the enumerations as the page shows them.
std::string process_state_name(int8_t state);
std::string robot_mode_name(int8_t mode);
std::string ir_validity_name(int8_t validity);
std::string gripper_state_name(int8_t state);

}  // namespace harvest::console
