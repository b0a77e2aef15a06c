#include "live_emoi_markov.hpp"

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "locd/client/client.hpp"
#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"

namespace locd::sim {
namespace fs = std::filesystem;

int run_four_positions_live(const fs::path& scenario_file, const LiveOptions& options, std::optional<uint64_t> seed,
                            bool json) {
  std::ostream& log = json ? std::cerr : std::cout;
  const emoi::FourPositionsScenario scenario = emoi::load_four_positions(scenario_file);
  const char* env = std::getenv("LOCD_SIM_MAP_DIR");
  const fs::path map_directory = env && *env ? fs::path(env) : fs::path("/tmp/locd_sim_maps");
  fs::create_directories(map_directory);
  std::vector<uint64_t> seeds;
  if (seed) {
    seeds.push_back(*seed);
  } else {
    for (int k = 0; k < scenario.runs; ++k) seeds.push_back(scenario.seed + static_cast<uint64_t>(k));
  }
  Client client(ClientOptions{options.domain_id, scenario.robot_id, 64});
  const auto timeout = server_timeout(options);
  if (!wait_for_server(client, options)) return 2;
  std::mutex mutex;
  std::map<int64_t, PoseUpdate> poses;  // by stamp
  client.on_pose(
      [&](const PoseUpdate& p) {
        std::lock_guard<std::mutex> lock(mutex);
        poses[p.estimate.header.stamp_ns] = p;
      },
      scenario.robot_id);

  int successes = 0, complete_runs = 0;
  std::vector<std::vector<double>> all_errors;
  std::vector<double> latencies_ms;
  for (uint64_t s : seeds) {
    const emoi::SimulatedRun run = emoi::build_run(scenario, s);
    const std::string map_name = scenario.name + "_seed" + std::to_string(s) + ".tif";
    locd::emoi::write_dsm_geotiff(run.dsm, map_directory / map_name);
    YAML::Node document = YAML::Load(scenario.localizer_config_text);
    document["params"]["map"] = map_name;
    document["params"]["cache"] = false;
    YAML::Emitter emitter;
    emitter << document;
    const auto status = client.request_session("emoi_markov", emitter.c_str(), std::chrono::milliseconds(120'000));
    if (!status || !status->request_ok) {
      std::cerr << "locsim: the server " << (status ? "refused the session: " + status->message : "did not answer")
                << "\n";
      fs::remove(map_directory / map_name);
      return 2;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      poses.clear();
    }
    // Sim stamps, shifted to this run's wall-clock start so every run's stamps are new.
    const int64_t base = std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::system_clock::now().time_since_epoch()).count();
    std::map<int64_t, std::pair<Eigen::Vector2d, int64_t>> scans;  // stamp -> truth, publish wall ns
    int64_t last_odometry = 0;
    const auto wall_start = std::chrono::steady_clock::now();
    emoi::simulate_measurements(scenario, run, s, [&](const Measurement& measurement, const Eigen::Isometry3d& truth) {
      Measurement m = measurement;
      const int64_t sim_ns = header_of(m).stamp_ns;
      // Scans one nanosecond after the odometry of the same instant: a pose stamped like a scan is
      // then the pose of a sensor update (odometry poses carry the odometry's stamp).
      const int64_t nudge = std::holds_alternative<LaserScan>(m) ? 1 : 0;
      std::visit([&](auto& value) { value.header.stamp_ns = base + sim_ns + nudge; }, m);
      std::this_thread::sleep_until(wall_start + std::chrono::nanoseconds(static_cast<int64_t>(sim_ns / options.rate)));
      const int64_t wall = std::chrono::duration_cast<std::chrono::nanoseconds>(
                               std::chrono::system_clock::now().time_since_epoch()).count();
      if (const auto* o = std::get_if<Odometry>(&m)) {
        client.publish(*o);
        last_odometry = o->header.stamp_ns;
      } else if (const auto* i = std::get_if<Imu>(&m)) {
        client.publish(*i);
      } else if (const auto* scan = std::get_if<LaserScan>(&m)) {
        client.publish(*scan);
        scans[scan->header.stamp_ns] = {truth.translation().head<2>(), wall};
      }
      std::lock_guard<std::mutex> lock(mutex);
      int updates = 0;
      for (const auto& [stamp, pose] : poses) updates += scans.count(stamp) ? 1 : 0;
      return updates >= scenario.updates;
    });
    // Wait until the server has caught up with everything published.
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      std::lock_guard<std::mutex> lock(mutex);
      int updates = 0;
      for (const auto& [stamp, pose] : poses) updates += scans.count(stamp) ? 1 : 0;
      if (updates >= scenario.updates || poses.count(last_odometry)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::vector<double> errors;
    {
      std::lock_guard<std::mutex> lock(mutex);
      for (const auto& [stamp, pose] : poses) {
        const auto scan = scans.find(stamp);
        if (scan == scans.end()) continue;
        errors.push_back((pose.estimate.pose.translation().head<2>() - scan->second.first).norm());
        latencies_ms.push_back(static_cast<double>(pose.received_wall_ns - scan->second.second) * 1e-6);
      }
    }
    const bool complete = static_cast<int>(errors.size()) >= scenario.updates;
    const bool ok = complete && errors[scenario.updates - 1] <= scenario.success_radius_m;
    complete_runs += complete ? 1 : 0;
    successes += ok ? 1 : 0;
    log << "seed " << s << (ok ? "  ok  " : "  FAIL") << "  error after each update [m]:";
    for (double e : errors) log << " " << e;
    log << std::endl;
    all_errors.push_back(errors);
    client.stop_session(timeout);
    fs::remove(map_directory / map_name);
  }
  std::sort(latencies_ms.begin(), latencies_ms.end());
  const double latency_p50 = latencies_ms.empty() ? 0.0 : latencies_ms[latencies_ms.size() / 2];
  if (json) {
    const nlohmann::ordered_json summary = {{"scenario", scenario.name},
                                            {"plugin", "emoi_markov"},
                                            {"mode", "live"},
                                            {"runs", seeds.size()},
                                            {"successes", successes},
                                            {"success_radius_m", scenario.success_radius_m},
                                            {"update_latency_p50_ms", latency_p50},
                                            {"errors_m", all_errors}};
    std::cout << summary.dump() << "\n";
  } else {
    std::cout << "success: " << successes << " / " << seeds.size() << " (belief maximum within "
              << scenario.success_radius_m << " m after update " << scenario.updates
              << "); sensor-update pose latency p50 " << latency_p50 << " ms (scan published -> pose received)\n";
  }
  return complete_runs == static_cast<int>(seeds.size()) ? 0 : 1;
}

}  // namespace locd::sim
