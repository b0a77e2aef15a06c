#include "live_exploration.hpp"

#include <iostream>
#include <stdexcept>

#include "locd/sim_icp_explorer/exploration_mission.hpp"

namespace locd::sim {

RemoteLocalizer::RemoteLocalizer(Client& client, std::chrono::milliseconds timeout)
    : client_(client), timeout_(timeout) {
  client_.on_pose(
      [this](const PoseUpdate& p) {
        std::lock_guard<std::mutex> lock(mutex_);
        poses_[p.estimate.header.stamp_ns] = p.estimate;
        changed_.notify_all();
      },
      client_.robot_id());
  client_.on_exploration_goal(
      [this](const ExplorationGoalUpdate& g) {
        std::lock_guard<std::mutex> lock(mutex_);
        goals_[g.goal.header.stamp_ns] = g.goal;
        changed_.notify_all();
      },
      client_.robot_id());
}

void RemoteLocalizer::set_pose(const PoseEstimate& pose) {
  const auto held = client_.set_initial_pose(pose, timeout_);
  if (!held || held->initial_pose_stamp_ns != pose.header.stamp_ns) {
    throw std::runtime_error("the server did not take the initial pose of robot '" + client_.robot_id() + "'" +
                             (held ? ": " + held->last_error : std::string()));
  }
}

UpdateResult RemoteLocalizer::update(const Measurement& measurement) {
  UpdateResult result;
  if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    client_.publish(*odometry);
    return result;
  }
  const auto* cloud = std::get_if<PointCloud>(&measurement);
  if (!cloud) throw std::invalid_argument("the exploration mission sends odometry and clouds only");
  const int64_t stamp = cloud->header.stamp_ns;
  client_.publish(*cloud);
  std::unique_lock<std::mutex> lock(mutex_);
  if (!changed_.wait_for(lock, timeout_, [&] { return poses_.count(stamp) && goals_.count(stamp); })) {
    throw std::runtime_error("no pose and exploration goal for the cloud stamped " + std::to_string(stamp) +
                             " ns within " + std::to_string(timeout_.count()) + " ms (see the robot's status: locctl status)");
  }
  result.estimate = poses_[stamp];
  result.exploration_goal = goals_[stamp];
  return result;
}

int run_exploration_live(const std::filesystem::path& scenario_file, const LiveOptions& options,
                         std::optional<uint64_t> seed, bool json) {
  const ExplorationScenario scenario = load_exploration_scenario(scenario_file);
  Client client(ClientOptions{options.domain_id, scenario.robot_id, 8});
  const auto timeout = server_timeout(options);
  if (!wait_for_server(client, options)) return 2;
  const auto status = client.request_session("", scenario.localizer_config, timeout);
  if (!status || !status->request_ok) {
    std::cerr << "locsim: the server " << (status ? "refused the session: " + status->message : "did not answer")
              << "\n";
    return 2;
  }
  RemoteLocalizer remote(client, timeout);
  ExplorationMissionResult result;
  try {
    result = run_exploration_mission(scenario, seed.value_or(scenario.seed), remote);
  } catch (const std::runtime_error& e) {
    std::cerr << "locsim: " << e.what() << "\n";
    return 2;
  }
  if (json)
    write_exploration_json(std::cout, scenario, result);
  else
    write_exploration_summary(std::cout, scenario, result);
  return result.scans.empty() ? 1 : 0;
}

}  // namespace locd::sim
