// Default channel names of the process graph (DESIGN.md section 2,
// docs/architecture.md). Processes take them from configuration where two
// instances of one process need different channels.
#pragma once

namespace harvest::channels {

inline constexpr const char* kCameraFixed = "CAMERA_FIXED";          // image_t
inline constexpr const char* kCameraHand = "CAMERA_HAND";            // image_t
inline constexpr const char* kCameraFixedZoom = "CAMERA_FIXED_ZOOM"; // image_t (teach by zooming)
inline constexpr const char* kFruitFixed = "FRUIT_FIXED";            // fruit_detections_t
inline constexpr const char* kFruitHand = "FRUIT_HAND";              // fruit_detections_t
inline constexpr const char* kFeaturesHand = "FEATURES_HAND";        // feature_tracks_t
inline constexpr const char* kFeaturesFixed = "FEATURES_FIXED";      // feature_tracks_t
inline constexpr const char* kFeatureMatches = "FEATURE_MATCHES";    // feature_matches_t
inline constexpr const char* kTargets = "TARGETS";                   // targets_t
inline constexpr const char* kRobotState = "ROBOT_STATE";            // robot_state_t
inline constexpr const char* kRobotCommand = "ROBOT_COMMAND";        // robot_command_t
inline constexpr const char* kIrRange = "IR_RANGE";                  // ir_range_t
inline constexpr const char* kGripperCommand = "GRIPPER_COMMAND";    // gripper_command_t
inline constexpr const char* kGripperState = "GRIPPER_STATE";        // gripper_state_t
inline constexpr const char* kHarvestStatus = "HARVEST_STATUS";      // harvest_status_t
inline constexpr const char* kOperatorCommand = "OPERATOR_COMMAND";  // operator_command_t
inline constexpr const char* kEmergencyStop = "EMERGENCY_STOP";      // emergency_stop_t
inline constexpr const char* kProcessStatus = "PROCESS_STATUS";      // process_status_t
inline constexpr const char* kConfig = "CONFIG";                     // config_snapshot_t
inline constexpr const char* kJournal = "JOURNAL";                   // node_journal_t (docs/replay.md)
inline constexpr const char* kDeputyStatus = "DEPUTY_STATUS";        // deputy_status_t
inline constexpr const char* kDeputyOutput = "DEPUTY_OUTPUT";        // deputy_output_t
inline constexpr const char* kLaunchOrder = "LAUNCH_ORDER";          // launch_order_t

}  // namespace harvest::channels
