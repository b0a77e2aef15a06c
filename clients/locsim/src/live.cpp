#include "live.hpp"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <variant>

#include "live_ros2.hpp"
#include "locd/client/client.hpp"
#include "locd/sim/report.hpp"
#include "locd/sim/simulation.hpp"

namespace locd::sim {

namespace {

int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Published {
  double t = 0.0;
  Pose2 truth;
  int64_t publish_wall_ns = 0;
};

// The server publishes a pose and then, when the plugin's localization state changed with that
// update, the status: a status that arrives within this much after a pose is that pose's.
constexpr int64_t kStatusLagNs = 5'000'000;
// Poses received less than this ago wait for the next scoring (their status may be on its way).
constexpr int64_t kScoringHoldNs = 100'000'000;

LocalizationState state_named(const std::string& name) {
  for (LocalizationState s : {LocalizationState::kTracking, LocalizationState::kUncertain, LocalizationState::kLost}) {
    if (name == localization_state_name(s)) return s;
  }
  return LocalizationState::kUnknown;
}

// What the robot's readers received (on Cyclone's threads), until the run scores it.
struct Inbox {
  std::mutex mutex;
  std::vector<PoseUpdate> received;
  std::vector<std::pair<int64_t, LocalizationState>> states;  // (received wall ns, state), in arrival order

  void pose(const PoseUpdate& p) {
    std::lock_guard<std::mutex> lock(mutex);
    received.push_back(p);
  }
  void status(const SessionStatus& st) {
    std::lock_guard<std::mutex> lock(mutex);
    states.emplace_back(wall_ns(), state_named(st.localization));
  }
  // The poses old enough that their status is in (all of them when final_batch), taken out;
  // `known_states` gets the states received so far.
  std::vector<PoseUpdate> take(bool final_batch, std::vector<std::pair<int64_t, LocalizationState>>& known_states) {
    std::lock_guard<std::mutex> lock(mutex);
    const int64_t hold_from = final_batch ? std::numeric_limits<int64_t>::max() : wall_ns() - kScoringHoldNs;
    const auto young = std::stable_partition(received.begin(), received.end(),
                                             [&](const PoseUpdate& p) { return p.received_wall_ns < hold_from; });
    std::vector<PoseUpdate> batch(received.begin(), young);
    received.erase(received.begin(), young);
    known_states = states;
    return batch;
  }
};

// A line a second: the last pose's error, update time and latency.
void print_progress(std::ostream& log, double t, const Scenario& scenario, const TrajectoryEvaluator& evaluator) {
  const auto& scored = evaluator.estimates();
  char line[256];
  if (scored.empty()) {
    std::snprintf(line, sizeof(line), "t=%.1fs robot=%s plugin=%s poses=0", t, scenario.robot.id.c_str(),
                  scenario.localizer.plugin.c_str());
  } else {
    const ScoredEstimate& last = scored.back();
    std::snprintf(line, sizeof(line), "t=%.1fs robot=%s plugin=%s error=%.3fm update=%.2fms latency=%.2fms poses=%zu",
                  t, scenario.robot.id.c_str(), scenario.localizer.plugin.c_str(), last.position_error_m,
                  last.update_ms, last.latency_ms.value_or(0.0), scored.size());
  }
  log << line << std::endl;
}

// Starts the robot's session (and, over ROS 2, waits for locd's topics); says why not on stderr.
bool start_session(Client& client, const Scenario& scenario, const std::string& config_text, LiveRos2Robot* ros2,
                   const LiveOptions& options) {
  const auto timeout = server_timeout(options);
  const auto status = client.request_session(scenario.localizer.plugin, config_text, timeout);
  if (!status) {
    std::cerr << "locsim: the server did not answer the session request for robot '" << scenario.robot.id
              << "' (plugin " << scenario.localizer.plugin << ") within " << options.server_timeout_s << " s\n";
    return false;
  }
  if (!status->request_ok) {
    std::cerr << "locsim: the server refused the session for robot '" << scenario.robot.id << "': " << status->message
              << "\n";
    return false;
  }
  if (ros2 && !ros2->wait_matched(timeout)) {
    std::cerr << "locsim: locd's ROS 2 topics for robot '" << scenario.robot.id << "' in namespace "
              << options.ros2_namespace << " did not appear within " << options.server_timeout_s << " s\n";
    return false;
  }
  return true;
}

// One stamped measurement, over ROS 2 where the robot speaks it; with each odometry, the ground
// truth at its stamp.
void publish(Client& client, LiveRos2Robot* ros2, const Measurement& measurement, const Pose2& truth) {
  std::visit(
      [&](const auto& value) {
        using T = std::decay_t<decltype(value)>;
        if constexpr (std::is_same_v<T, Odometry>) {
          PoseEstimate truth_pose;
          truth_pose.header.stamp_ns = value.header.stamp_ns;
          truth_pose.header.frame_id = "map";
          truth_pose.pose = truth.to_isometry();
          truth_pose.covariance = Matrix6d::Zero();
          client.publish_ground_truth(truth_pose);
        }
        if (!ros2 || !ros2->publish(value)) client.publish(value);
      },
      measurement);
}

// The longest wait between two poses received (wall clock), if two were.
std::optional<double> max_gap_ms(std::vector<int64_t> arrivals_ns) {
  std::optional<double> gap;
  std::sort(arrivals_ns.begin(), arrivals_ns.end());
  for (size_t i = 1; i < arrivals_ns.size(); ++i) {
    gap = std::max(gap.value_or(0.0), static_cast<double>(arrivals_ns[i] - arrivals_ns[i - 1]) * 1e-6);
  }
  return gap;
}

}  // namespace

std::chrono::milliseconds server_timeout(const LiveOptions& options) {
  return std::chrono::milliseconds(static_cast<int64_t>(options.server_timeout_s * 1000));
}

bool wait_for_server(Client& client, const LiveOptions& options) {
  if (client.wait_for_server(server_timeout(options))) return true;
  std::cerr << "locsim: no locd server answered on DDS domain " << options.domain_id << " within "
            << options.server_timeout_s << " s (is locd running with the same CYCLONEDDS_URI and domain?)\n";
  return false;
}

int run_live(const Scenario& scenario, const LiveOptions& options) {
  std::ostream& log = options.json ? std::cerr : std::cout;
  RunResult result;
  result.plugin = scenario.localizer.plugin;
  result.scenario = scenario.name;
  result.robot_id = scenario.robot.id;
  result.seed = options.seed.value_or(scenario.seed);
  result.duration_s = options.duration_s.value_or(scenario.duration_s);

  Client client(ClientOptions{options.domain_id, scenario.robot.id, 8});
  const auto timeout = server_timeout(options);
  if (!wait_for_server(client, options)) return 2;

  Inbox inbox;
  auto record = [&](const PoseUpdate& p) { inbox.pose(p); };
  client.on_status([&](const SessionStatus& st) { inbox.status(st); }, scenario.robot.id);
  std::string config_text = scenario.localizer.config_text;
  std::unique_ptr<LiveRos2Robot> ros2;  // --ros2: scans, odometry and poses over ROS 2 instead
  if (options.ros2_namespace.empty()) {
    client.on_pose(record, scenario.robot.id);
  } else {
    ros2 = std::make_unique<LiveRos2Robot>(scenario, result.seed, options, record);
    config_text += "\n" + ros2->config_section();
  }

  if (!start_session(client, scenario, config_text, ros2.get(), options)) return 2;

  Simulation simulation(scenario, result.seed, result.duration_s, 0);
  // The robot's clock: stamps are the simulated measurement times, shifted to this run's
  // wall-clock start (so every run's stamps are new), as a robot stamps a measurement when it is
  // taken. Publish times are only for the latency figures: a late publish (a loaded machine)
  // must not bend the dt a plugin derives velocities from.
  const int64_t clock_origin_ns = wall_ns();
  PoseEstimate initial = simulation.initial_pose();
  initial.header.stamp_ns = clock_origin_ns;
  const auto held = client.set_initial_pose(initial, timeout);
  if (!held || held->initial_pose_stamp_ns != initial.header.stamp_ns) {
    std::cerr << "locsim: the server did not take the initial pose of robot '" << scenario.robot.id << "' within "
              << options.server_timeout_s << " s" << (held ? ": " + held->last_error : std::string()) << "\n";
    return 2;
  }

  std::map<int64_t, Published> published;  // by stamp
  std::vector<int64_t> pose_arrivals_ns;    // wall clock, of the poses scored
  const std::optional<SimulatedEvent> event = simulation.event();
  result.event = event;
  TrajectoryEvaluator evaluator(scenario.convergence_threshold_m, event ? std::optional<double>(event->t) : std::nullopt);
  // final_batch: score every pose received; else only those old enough that their status is in.
  auto score_received = [&](bool final_batch) {
    std::vector<std::pair<int64_t, LocalizationState>> known_states;
    const std::vector<PoseUpdate> batch = inbox.take(final_batch, known_states);
    for (const auto& p : batch) {
      const auto it = published.find(p.estimate.header.stamp_ns);
      if (it == published.end()) continue;  // a pose for a stamp this run never published
      const double latency_ms = static_cast<double>(p.received_wall_ns - it->second.publish_wall_ns) * 1e-6;
      pose_arrivals_ns.push_back(p.received_wall_ns);
      LocalizationState state = LocalizationState::kUnknown;
      for (const auto& [at, s] : known_states) {
        if (at > p.received_wall_ns + kStatusLagNs) break;
        state = s;
      }
      evaluator.add(it->second.t, p.estimate, it->second.truth, state, p.update_ms, latency_ms);
    }
  };
  const auto wall_start = std::chrono::steady_clock::now();
  double next_print = 1.0;
  while (auto m = simulation.next()) {
    const auto due = wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(m->t / options.rate));
    std::this_thread::sleep_until(due);
    const int64_t stamp = clock_origin_ns + static_cast<int64_t>(std::llround(m->t * 1e9));
    const Pose2 truth = simulation.truth().at(m->t).pose;
    std::visit([&](auto& value) { value.header.stamp_ns = stamp; }, m->measurement);
    published[stamp] = Published{m->t, truth, wall_ns()};
    ++result.measurements;
    publish(client, ros2.get(), m->measurement, truth);
    if (m->t >= next_print) {
      score_received(false);
      print_progress(log, m->t, scenario, evaluator);
      next_print += 1.0;
    }
  }
  // Poses still in flight.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  score_received(true);

  // The server's counters for this robot: what it refused and why.
  for (const auto& st : client.statuses()) {
    if (st.robot_id != scenario.robot.id) continue;
    result.rejected = st.rejected;
    result.last_rejection = st.last_error;
  }
  result.summary = evaluator.summary();
  result.summary.max_pose_gap_ms = max_gap_ms(std::move(pose_arrivals_ns));
  result.estimates = evaluator.estimates();
  for (const auto& s : simulation.truth().samples()) result.truth_path.push_back(s.pose);
  if (result.summary.updates == 0) {
    std::cerr << "locsim: no pose received from the server for robot '" << scenario.robot.id
              << "' (see `locctl status " << scenario.robot.id << "`)\n";
    return 1;
  }
  report_run(result, scenario.map, options.json, options.plot_file);
  return 0;
}

}  // namespace locd::sim
