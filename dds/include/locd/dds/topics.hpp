// Topic names and their QoS: one place, used by the server, the clients and locsim.
// README "Topics" documents each; a new topic goes here first.
#pragma once

#include <string>

namespace locd::topics {

// Addressing. Every per-robot topic travels in the DDS partition `robot.<robot_id>`: a robot's
// readers receive only that robot's data, and DDS Security grants a robot identity exactly its
// own partition. The server reads every robot with the wildcard partition and refuses a sample
// whose robot_id is not its writer's partition. ServerInfo and server-to-server topics use the
// default partition ("").
inline constexpr const char* kRobotPartitionPrefix = "robot.";
inline constexpr const char* kAllRobotsPartition = "robot.*";
inline std::string robot_partition(const std::string& robot_id) { return kRobotPartitionPrefix + robot_id; }

// Sensors, robot -> locd. Reliable, keep-last (small depth), keyed by robot_id.
inline constexpr const char* kOdometry = "locd/odometry";
inline constexpr const char* kImu = "locd/imu";
inline constexpr const char* kScan = "locd/scan";
inline constexpr const char* kCloud = "locd/cloud";
inline constexpr const char* kImage = "locd/image";
inline constexpr const char* kDetections = "locd/detections";

// Outputs, locd -> anyone.
inline constexpr const char* kPose = "locd/pose";                  // reliable, keep-last 1
inline constexpr const char* kDiagnostics = "locd/diagnostics";    // reliable, keep-last
inline constexpr const char* kGrid = "locd/grid";                  // transient-local
inline constexpr const char* kMapCloud = "locd/map_cloud";         // transient-local
inline constexpr const char* kLandmarkMap = "locd/landmark_map";   // transient-local
inline constexpr const char* kExplorationGoal = "locd/exploration_goal";  // transient-local, keep-last 1

// Control and state.
inline constexpr const char* kSessionRequest = "locd/session_request";  // transient-local
inline constexpr size_t kMaxConfigYamlBytes = 262144;                     // SessionRequest.config_yaml's bound
inline constexpr const char* kSessionStatus = "locd/session_status";    // transient-local
inline constexpr const char* kInitialPose = "locd/initial_pose";        // transient-local
inline constexpr const char* kServerInfo = "locd/server_info";          // transient-local
inline constexpr const char* kMapSaveRequest = "locd/map_save_request";  // reliable, volatile

// Between servers (default partition): which server serves which robot, and where a robot
// resumes when another server takes it over. Written with a short liveliness lease.
inline constexpr const char* kServingClaim = "locd/serving";       // transient-local
inline constexpr const char* kResumeState = "locd/resume_state";   // transient-local, keep-last 1

// Simulation ground truth, locsim -> evaluators (PoseEstimate).
inline constexpr const char* kGroundTruth = "locd/ground_truth";

}  // namespace locd::topics
