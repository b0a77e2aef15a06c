#include "fleet.hpp"

#include <dirent.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <functional>
#include <variant>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <sstream>
#include <thread>
#include <unordered_map>
#include <unordered_set>

#include "locd/client/wire.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "locd/sim/simulation.hpp"

namespace locd::sim {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

// Robots whose messages one set of writers carries (a publisher in all their partitions): a
// fleet of thousands needs thousands of endpoints less. The server checks each sample's robot id
// against its writer's partitions as it would for a robot's own writer.
constexpr size_t kRobotsPerWriter = 100;
// Poses still in flight when the last message has gone.
constexpr auto kDrain = std::chrono::milliseconds(1500);

int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  const size_t k = static_cast<size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

// ------------------------------------------------------------------ the servers' CPU and memory

struct ProcessSample {
  double cpu_s = 0.0;   // user + system of the servers and their workers (reaped ones included)
  double pss_mb = 0.0;  // proportional set size of the servers and their live workers
  size_t processes = 0;
};

// Fields 14-17 of /proc/PID/stat: utime, stime, cutime, cstime (clock ticks); and the parent.
bool read_stat(pid_t pid, double& cpu_s, double& children_cpu_s, pid_t& parent) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(in, text)) return false;
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return false;
  std::istringstream fields(text.substr(close + 2));
  std::string state;
  long long ppid = 0, skip = 0, utime = 0, stime = 0, cutime = 0, cstime = 0;
  fields >> state >> ppid;
  for (int i = 0; i < 9; ++i) fields >> skip;
  fields >> utime >> stime >> cutime >> cstime;
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  cpu_s = static_cast<double>(utime + stime) / tick;
  children_cpu_s = static_cast<double>(cutime + cstime) / tick;
  parent = static_cast<pid_t>(ppid);
  return true;
}

double read_pss_mb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/smaps_rollup");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Pss:", 0) == 0) return std::stod(line.substr(4)) / 1024.0;
  }
  return 0.0;
}

ProcessSample sample_servers(const std::vector<pid_t>& servers) {
  ProcessSample s;
  std::vector<std::pair<pid_t, pid_t>> all;  // pid, parent
  if (DIR* proc = opendir("/proc")) {
    while (dirent* entry = readdir(proc)) {
      char* end = nullptr;
      const long pid = std::strtol(entry->d_name, &end, 10);
      if (*end != '\0' || pid <= 0) continue;
      double cpu = 0, children = 0;
      pid_t parent = 0;
      if (read_stat(static_cast<pid_t>(pid), cpu, children, parent)) all.emplace_back(static_cast<pid_t>(pid), parent);
    }
    closedir(proc);
  }
  for (const pid_t server : servers) {
    double cpu = 0, children = 0;
    pid_t parent = 0;
    if (!read_stat(server, cpu, children, parent)) continue;
    s.cpu_s += cpu + children;
    s.pss_mb += read_pss_mb(server);
    ++s.processes;
    for (const auto& [pid, ppid] : all) {
      if (ppid != server) continue;
      double worker_cpu = 0, worker_children = 0;
      pid_t ignored = 0;
      if (!read_stat(pid, worker_cpu, worker_children, ignored)) continue;
      s.cpu_s += worker_cpu;
      s.pss_mb += read_pss_mb(pid);
      ++s.processes;
    }
  }
  return s;
}

// ------------------------------------------------------------------ the fleet's DDS side

struct Item {
  double t;  // s since the run's start
  Measurement measurement;
};

struct Run {
  std::vector<Item> items;
  PoseEstimate initial_pose;
  std::unordered_map<int64_t, size_t> kind_at;  // t in ns -> measurement kind (variant index)
  std::unordered_map<int64_t, Eigen::Vector2d> truth_at;  // t in ns -> true position (outage report)
};

// A pose received, for the outage report.
struct Arrival {
  int64_t wall_ns;
  int64_t t_ns;  // the robot's time of its stamp
  double error_m;
};

// The writers of up to kRobotsPerWriter robots, in all their partitions.
struct WriterGroup {
  explicit WriterGroup(const dds::Participant& p, const dds::Partitions& partitions)
      : requests(p, topics::kSessionRequest, dds::QosProfile::kState, 8, partitions),
        initial_poses(p, topics::kInitialPose, dds::QosProfile::kState, 8, partitions),
        odometry(p, topics::kOdometry, dds::QosProfile::kSensor, 64, partitions),
        imu(p, topics::kImu, dds::QosProfile::kSensor, 64, partitions),
        scan(p, topics::kScan, dds::QosProfile::kSensor, 64, partitions),
        cloud(p, topics::kCloud, dds::QosProfile::kSensor, 8, partitions),
        image(p, topics::kImage, dds::QosProfile::kSensor, 8, partitions),
        detections(p, topics::kDetections, dds::QosProfile::kSensor, 64, partitions) {}
  dds::Writer<locd_msg_SessionRequest> requests;
  dds::Writer<locd_msg_InitialPose> initial_poses;
  dds::Writer<locd_msg_Odometry> odometry;
  dds::Writer<locd_msg_Imu> imu;
  dds::Writer<locd_msg_LaserScan> scan;
  dds::Writer<locd_msg_PointCloud> cloud;
  dds::Writer<locd_msg_Image> image;
  dds::Writer<locd_msg_LandmarkDetections> detections;

  void write(const std::string& robot, const Measurement& m) {
    std::visit(
        [&](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, Odometry>) dds::write(odometry, robot, v);
          if constexpr (std::is_same_v<T, Imu>) dds::write(imu, robot, v);
          if constexpr (std::is_same_v<T, LaserScan>) dds::write(scan, robot, v);
          if constexpr (std::is_same_v<T, PointCloud>) dds::write(cloud, robot, v);
          if constexpr (std::is_same_v<T, Image>) dds::write(image, robot, v);
          if constexpr (std::is_same_v<T, LandmarkDetections>) dds::write(detections, robot, v);
        },
        m);
  }
};

// What the servers answer, by robot.
struct Observations {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<SessionStatus> status;          // latest per robot
  std::vector<double> latency_ms;             // every pose
  std::vector<std::array<size_t, 6>> answered;  // per robot: poses whose stamp is a message of each kind
  std::map<long, std::pair<size_t, std::vector<double>>> per_second;  // second -> poses, latencies
  size_t poses = 0;
  size_t unmatched = 0;  // poses whose stamp is no message of this run
  std::vector<int64_t> last_pose_ns;  // per robot, wall clock of the last pose received (0: none)
  std::vector<std::unordered_set<int64_t>> stamps;  // per robot, the stamps of the poses received
  std::vector<std::vector<Arrival>> arrivals;       // per robot, with --outage-report
  size_t duplicated = 0;  // poses for a robot and stamp received before (from another server)
  std::vector<double> max_gap_ms;     // per robot, the longest wait between two poses
};

// Per robot: its longest wait between two poses, when it ended, and the errors then and 1 s and
// 5 s (robot time) later (null when the run ended before).
Json outage_report(const std::vector<std::vector<Arrival>>& arrivals) {
  Json wait_ms = Json::array(), served_again = Json::array(), first = Json::array(), after_1s = Json::array(),
       after_5s = Json::array();
  auto error_after = [](const std::vector<Arrival>& a, size_t from, int64_t later_ns) -> Json {
    for (size_t j = from; j < a.size(); ++j) {
      if (a[j].t_ns >= a[from].t_ns + later_ns) return a[j].error_m;
    }
    return nullptr;
  };
  for (const auto& a : arrivals) {
    size_t end = 0;  // the arrival that ended the longest wait
    int64_t longest = -1;
    for (size_t j = 1; j < a.size(); ++j) {
      if (a[j].wall_ns - a[j - 1].wall_ns > longest) {
        longest = a[j].wall_ns - a[j - 1].wall_ns;
        end = j;
      }
    }
    if (end == 0) {
      wait_ms.push_back(nullptr);
      served_again.push_back(nullptr);
      first.push_back(nullptr);
      after_1s.push_back(nullptr);
      after_5s.push_back(nullptr);
      continue;
    }
    wait_ms.push_back(static_cast<double>(a[end].wall_ns - a[end - 1].wall_ns) * 1e-6);
    served_again.push_back(a[end].wall_ns);
    first.push_back(a[end].error_m);
    after_1s.push_back(error_after(a, end, 1'000'000'000));
    after_5s.push_back(error_after(a, end, 5'000'000'000));
  }
  return {{"longest_wait_ms", wait_ms},
          {"served_again_wall_ns", served_again},
          {"error_m_first", first},
          {"error_m_1s_later", after_1s},
          {"error_m_5s_later", after_5s}};
}

void write_plot(const std::string& file, const std::map<long, std::pair<size_t, std::vector<double>>>& per_second,
                size_t robots) {
  constexpr int kWidth = 1000, kPanel = 260, kMargin = 60;
  cv::Mat image(2 * kPanel + 3 * kMargin / 2, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  if (per_second.empty()) {
    cv::imwrite(file, image);
    return;
  }
  const long first = per_second.begin()->first, last = per_second.rbegin()->first;
  double max_poses = 1, max_latency = 0.1;
  std::vector<std::tuple<long, double, double, double>> rows;  // second, poses, p50, p99
  for (const auto& [second, entry] : per_second) {
    const double p50 = percentile(entry.second, 0.5), p99 = percentile(entry.second, 0.99);
    rows.emplace_back(second, static_cast<double>(entry.first), p50, p99);
    max_poses = std::max(max_poses, static_cast<double>(entry.first));
    if (std::isfinite(p99)) max_latency = std::max(max_latency, p99);
  }
  auto x_of = [&](long s) {
    return kMargin + static_cast<int>((kWidth - 2 * kMargin) * static_cast<double>(s - first) /
                                      std::max<double>(1.0, static_cast<double>(last - first)));
  };
  auto panel = [&](int top, double max, int series, const cv::Scalar& colour) {
    std::vector<cv::Point> points;
    for (const auto& row : rows) {
      const double v = series == 0 ? std::get<1>(row) : series == 1 ? std::get<2>(row) : std::get<3>(row);
      if (!std::isfinite(v)) continue;
      points.emplace_back(x_of(std::get<0>(row)), top + kPanel - static_cast<int>(kPanel * v / max));
    }
    if (points.size() > 1) cv::polylines(image, points, false, colour, 2, cv::LINE_AA);
  };
  const int top1 = kMargin / 2, top2 = kMargin + kPanel;
  cv::rectangle(image, {kMargin, top1}, {kWidth - kMargin, top1 + kPanel}, {160, 160, 160});
  cv::rectangle(image, {kMargin, top2}, {kWidth - kMargin, top2 + kPanel}, {160, 160, 160});
  panel(top1, max_poses * 1.1, 0, {40, 120, 40});
  panel(top2, max_latency * 1.1, 1, {200, 80, 0});
  panel(top2, max_latency * 1.1, 2, {40, 40, 220});
  char text[200];
  std::snprintf(text, sizeof text, "%zu robots: poses received per second (max %.0f)", robots, max_poses);
  cv::putText(image, text, {kMargin + 8, top1 + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  std::snprintf(text, sizeof text, "latency per second, ms: p50 (blue) and p99 (red); top = %.2f ms", max_latency * 1.1);
  cv::putText(image, text, {kMargin + 8, top2 + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  std::snprintf(text, sizeof text, "seconds 0 .. %ld of the run", last - first);
  cv::putText(image, text, {kMargin, top2 + kPanel + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::imwrite(file, image);
}

// What the fleet replays: K simulated runs (robot i drives run i % K, its messages i / n of the
// smallest sensor period later, so the fleet's load spreads) and the robots' ids.
struct FleetPlan {
  size_t n = 0, k_runs = 1;
  double duration = 0.0, rate = 1.0;
  double smallest_period = 1.0;  // the shortest gap between two messages of one stream
  std::vector<Run> runs;         // stamps relative to their start
  std::vector<std::string> ids;
  std::unordered_map<std::string, size_t> index_of;

  const Run& run_of(size_t i) const { return runs[i % k_runs]; }
  int64_t offset_ns(size_t i) const {
    return static_cast<int64_t>(std::llround(smallest_period * 1e9 * static_cast<double>(i) / static_cast<double>(n)));
  }
};

FleetPlan plan_fleet(const Scenario& scenario, const FleetOptions& options) {
  FleetPlan plan;
  plan.n = options.robots;
  plan.k_runs = std::max<size_t>(1, std::min(options.distinct_runs, plan.n));
  plan.duration = options.duration_s.value_or(scenario.duration_s);
  plan.rate = options.rate;
  const uint64_t seed = options.seed.value_or(scenario.seed);
  plan.runs.resize(plan.k_runs);
  for (size_t k = 0; k < plan.k_runs; ++k) {
    Simulation simulation(scenario, seed + k, plan.duration, 0);
    Run& run = plan.runs[k];
    run.initial_pose = simulation.initial_pose();
    std::map<size_t, double> last_t;
    while (auto m = simulation.next()) {
      const size_t kind = m->measurement.index();
      if (auto it = last_t.find(kind); it != last_t.end() && m->t > it->second) {
        plan.smallest_period = std::min(plan.smallest_period, m->t - it->second);
      }
      last_t[kind] = m->t;
      run.kind_at[std::llround(m->t * 1e9)] = kind;
      if (options.outage_report) {
        const Pose2 truth = simulation.truth().at(m->t).pose;
        run.truth_at[std::llround(m->t * 1e9)] = Eigen::Vector2d(truth.x, truth.y);
      }
      run.items.push_back({m->t, std::move(m->measurement)});
    }
  }
  plan.ids.resize(plan.n);
  for (size_t i = 0; i < plan.n; ++i) {
    std::ostringstream id;
    id << options.robot_prefix << std::setw(5) << std::setfill('0') << i;
    plan.ids[i] = id.str();
    plan.index_of[plan.ids[i]] = i;
  }
  return plan;
}

// A pose of robot i received at wall time `now` (under seen.mutex): matched to the message whose
// stamp it carries, timed against when that message was due, counted.
void record_pose(const FleetPlan& plan, const locd_msg_PoseEstimate& m, size_t i, int64_t now, int64_t origin_ns,
                 bool outage_report, Observations& seen) {
  const int64_t t_ns = m.header.stamp_ns - origin_ns - plan.offset_ns(i);
  const auto& kinds = plan.run_of(i).kind_at;
  const auto kind = kinds.find(t_ns);
  if (kind == kinds.end()) {
    ++seen.unmatched;
    return;
  }
  if (!seen.stamps[i].insert(m.header.stamp_ns).second) {
    ++seen.duplicated;
    return;
  }
  // When the message was due (stamps are the run's clock, publishing paced by --rate).
  const double due = static_cast<double>(origin_ns) + static_cast<double>(t_ns + plan.offset_ns(i)) / plan.rate;
  const double latency_ms = (static_cast<double>(now) - due) * 1e-6;
  ++seen.answered[i][kind->second];
  ++seen.poses;
  if (seen.last_pose_ns[i] != 0) {
    seen.max_gap_ms[i] = std::max(seen.max_gap_ms[i], static_cast<double>(now - seen.last_pose_ns[i]) * 1e-6);
  }
  seen.last_pose_ns[i] = now;
  if (outage_report) {
    const auto& truth_at = plan.run_of(i).truth_at;
    const auto truth = truth_at.find(t_ns);
    const Eigen::Vector2d position(m.pose.position.x, m.pose.position.y);
    const double error = truth == truth_at.end() ? std::nan("") : (position - truth->second).norm();
    seen.arrivals[i].push_back({now, t_ns, error});
  }
  seen.latency_ms.push_back(latency_ms);
  auto& second = seen.per_second[static_cast<long>((now - origin_ns) / 1'000'000'000)];
  ++second.first;
  second.second.push_back(latency_ms);
}

// Until every robot's status satisfies `done`; says how many did not, with an example, if not.
bool wait_all(const FleetPlan& plan, const FleetOptions& options, Observations& seen,
              const std::function<bool(const SessionStatus&)>& done, const char* what) {
  std::unique_lock<std::mutex> lock(seen.mutex);
  const bool ok = seen.changed.wait_for(lock, std::chrono::duration<double>(options.server_timeout_s), [&] {
    return std::all_of(seen.status.begin(), seen.status.end(), done);
  });
  if (!ok) {
    size_t count = 0;
    std::string example;
    for (size_t i = 0; i < plan.n; ++i) {
      if (done(seen.status[i])) {
        ++count;
      } else if (example.empty()) {
        example = plan.ids[i] + ": state '" + seen.status[i].state + "', " + seen.status[i].message + " " +
                  seen.status[i].last_error;
      }
    }
    std::cerr << "locsim fleet: " << count << " of " << plan.n << " robots " << what << " within "
              << options.server_timeout_s << " s; e.g. " << example << "\n";
  }
  return ok;
}

// What publishing the fleet's messages took.
struct Drive {
  size_t published = 0;
  std::vector<double> lag_ms;  // how late each message went out
  double run_s = 0.0;
  int64_t last_published_ns = 0;
};

// Publishes every robot's messages when due (from t_origin, wall clock), numbered per robot and
// stream; a line a second unless --json.
Drive drive_fleet(const FleetPlan& plan, const FleetOptions& options, int64_t t_origin,
                  const std::vector<std::unique_ptr<WriterGroup>>& groups, Observations& seen, std::ostream& log) {
  Drive drive;
  const auto run_start = Clock::now();
  using Event = std::pair<int64_t, size_t>;  // due (wall ns), robot
  std::priority_queue<Event, std::vector<Event>, std::greater<>> due;
  std::vector<size_t> next(plan.n, 0);
  std::vector<std::array<uint64_t, 6>> sequence(plan.n, std::array<uint64_t, 6>{});
  auto due_of = [&](size_t i) {
    const Item& item = plan.run_of(i).items[next[i]];
    return t_origin + static_cast<int64_t>((item.t * 1e9 + static_cast<double>(plan.offset_ns(i))) / plan.rate);
  };
  for (size_t i = 0; i < plan.n; ++i) {
    if (!plan.run_of(i).items.empty()) due.emplace(due_of(i), i);
  }
  drive.lag_ms.reserve(1 << 20);
  long next_report = 1;
  while (!due.empty()) {
    const auto [when, i] = due.top();
    due.pop();
    int64_t now = wall_ns();
    if (when > now) {
      std::this_thread::sleep_for(std::chrono::nanoseconds(when - now));
      now = wall_ns();
    }
    drive.lag_ms.push_back(static_cast<double>(now - when) * 1e-6);
    const Item& item = plan.run_of(i).items[next[i]];
    Measurement m = item.measurement;
    std::visit(
        [&](auto& v) {
          v.header.stamp_ns = t_origin + std::llround(item.t * 1e9) + plan.offset_ns(i);
          v.header.sequence = ++sequence[i][m.index()];
        },
        m);
    groups[i / kRobotsPerWriter]->write(plan.ids[i], m);
    ++drive.published;
    if (++next[i] < plan.run_of(i).items.size()) due.emplace(due_of(i), i);
    if (!options.json && now - t_origin >= next_report * 1'000'000'000L) {
      std::lock_guard<std::mutex> lock(seen.mutex);
      log << "t=" << next_report << "s published=" << drive.published << " poses=" << seen.poses << std::endl;
      ++next_report;
    }
  }
  drive.run_s = std::chrono::duration<double>(Clock::now() - run_start).count();
  drive.last_published_ns = wall_ns();
  return drive;
}

// The run's figures (under seen.mutex): poses expected and received, latencies, gaps, the
// servers' counters, CPU and memory.
Json fleet_report(const Scenario& scenario, const FleetOptions& options, const FleetPlan& plan, const Observations& seen,
                  const Drive& drive, double sessions_started_s, const ProcessSample& before_sessions,
                  const ProcessSample& before, const ProcessSample& after) {
  const size_t n = plan.n;
  std::array<size_t, 6> published_by_kind{}, answered_by_kind{};
  for (size_t i = 0; i < n; ++i) {
    for (const auto& item : plan.run_of(i).items) ++published_by_kind[item.measurement.index()];
    for (size_t k = 0; k < 6; ++k) answered_by_kind[k] += seen.answered[i][k];
  }
  size_t pose_kind = 0;
  for (size_t k = 1; k < 6; ++k) {
    if (answered_by_kind[k] > answered_by_kind[pose_kind]) pose_kind = k;
  }
  uint64_t lost = 0, dropped = 0, rejected = 0, received = 0, failures = 0;
  size_t running = 0;
  std::map<std::string, size_t> servers;
  for (const auto& s : seen.status) {
    lost += s.lost;
    dropped += s.dropped;
    rejected += s.rejected;
    received += s.received;
    failures += s.failures;
    running += s.state == "running";
    ++servers[s.server_id];
  }
  const size_t expected_poses = published_by_kind[pose_kind];
  // Robots that got no pose in the last two seconds of driving (lost their server for good).
  size_t silent = 0;
  for (size_t i = 0; i < n; ++i) silent += seen.last_pose_ns[i] < drive.last_published_ns - 2'000'000'000;
  const double max_gap_ms = n == 0 ? 0.0 : *std::max_element(seen.max_gap_ms.begin(), seen.max_gap_ms.end());
  const double cpu_s = after.cpu_s - before.cpu_s;
  const double run_s = drive.run_s;
  static const char* kKindNames[] = {"odometry", "imu", "scan", "cloud", "image", "detections"};

  Json out = {{"robots", n},
              {"scenario", scenario.name},
              {"plugin", scenario.localizer.plugin},
              {"rate", options.rate},
              {"duration_s", plan.duration},
              {"distinct_runs", plan.k_runs},
              {"sessions_started_s", sessions_started_s},
              {"messages_published", drive.published},
              {"messages_per_s", static_cast<double>(drive.published) / run_s},
              {"pose_kind", kKindNames[pose_kind]},
              {"poses_expected", expected_poses},
              {"poses_received", seen.poses},
              {"poses_missing", expected_poses > seen.poses ? expected_poses - seen.poses : 0},
              {"poses_duplicated", seen.duplicated},
              {"poses_per_s", static_cast<double>(seen.poses) / run_s},
              {"latency_ms_p50", percentile(seen.latency_ms, 0.5)},
              {"latency_ms_p99", percentile(seen.latency_ms, 0.99)},
              {"latency_ms_max", seen.latency_ms.empty() ? 0.0 : *std::max_element(seen.latency_ms.begin(), seen.latency_ms.end())},
              {"generator_lag_ms_p99", percentile(drive.lag_ms, 0.99)},
              {"max_pose_gap_ms", max_gap_ms},
              {"robots_silent_at_end", silent},
              {"server_received", received},
              {"server_lost_in_transit", lost},
              {"server_dropped", dropped},
              {"server_rejected", rejected},
              {"plugin_failures", failures},
              {"sessions_running", running}};
  Json by_server = Json::object();
  for (const auto& [server, count] : servers) by_server[server] = count;
  out["robots_by_server"] = by_server;
  if (!options.server_pids.empty()) {
    out["server_processes"] = after.processes;
    out["server_cpu_percent"] = 100.0 * cpu_s / run_s;
    out["server_cpu_ms_per_robot_s"] = 1000.0 * cpu_s / run_s / static_cast<double>(n);
    out["server_memory_mb"] = after.pss_mb;
    out["server_memory_mb_per_session"] = (after.pss_mb - before_sessions.pss_mb) / static_cast<double>(n);
  }
  if (options.outage_report) out["outage"] = outage_report(seen.arrivals);
  return out;
}

}  // namespace

// The fleet: a plan of K simulated runs, writers and readers for every robot, sessions started and
// initial poses taken, every message published when due, then the figures.
int run_fleet(const Scenario& scenario, const FleetOptions& options) {
  std::ostream& log = options.json ? std::cerr : std::cout;
  const FleetPlan plan = plan_fleet(scenario, options);
  const size_t n = plan.n;

  dds::Participant participant(options.domain_id);
  std::vector<std::unique_ptr<WriterGroup>> groups;
  for (size_t first = 0; first < n; first += kRobotsPerWriter) {
    dds::Partitions partitions;
    for (size_t i = first; i < std::min(n, first + kRobotsPerWriter); ++i) {
      partitions.push_back(topics::robot_partition(plan.ids[i]));
    }
    groups.push_back(std::make_unique<WriterGroup>(participant, partitions));
  }

  Observations seen;
  seen.status.resize(n);
  seen.answered.resize(n, std::array<size_t, 6>{});
  seen.last_pose_ns.resize(n, 0);
  seen.stamps.resize(n);
  seen.arrivals.resize(n);
  seen.max_gap_ms.resize(n, 0.0);
  int64_t origin_ns = 0;  // stamp of t = 0 (set before any sensor message)
  const dds::Partitions every_robot{topics::kAllRobotsPartition};
  dds::Reader<locd_msg_SessionStatus> statuses(
      participant, topics::kSessionStatus, dds::QosProfile::kState,
      [&](const locd_msg_SessionStatus& m) {
        const auto it = plan.index_of.find(dds::to_string(m.robot_id));
        if (it == plan.index_of.end()) return;
        SessionStatus status = status_from_wire(m);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.status[it->second] = std::move(status);
        seen.changed.notify_all();
      },
      8, every_robot);
  dds::Reader<locd_msg_PoseEstimate> poses(
      participant, topics::kPose, dds::QosProfile::kPose,
      [&](const locd_msg_PoseEstimate& m) {
        const int64_t now = wall_ns();
        const auto it = plan.index_of.find(dds::to_string(m.robot_id));
        if (it == plan.index_of.end()) return;
        std::lock_guard<std::mutex> lock(seen.mutex);
        if (origin_ns != 0) record_pose(plan, m, it->second, now, origin_ns, options.outage_report, seen);
      },
      64, every_robot);

  // Discovery: every group's writers and the readers matched by a server.
  const auto discovery_deadline = Clock::now() + std::chrono::duration<double>(options.server_timeout_s);
  for (const auto& g : groups) {
    while (g->requests.matched() == 0 || g->odometry.matched() == 0) {
      if (Clock::now() > discovery_deadline) {
        std::cerr << "locsim fleet: no locd server on domain " << options.domain_id << " matched the fleet's writers within "
                  << options.server_timeout_s << " s\n";
        return 2;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  const ProcessSample before_sessions = sample_servers(options.server_pids);

  // Sessions: one request each, then the initial poses, each waited for on the status topic.
  const uint64_t request_id = static_cast<uint64_t>(wall_ns());
  const auto start_requests = Clock::now();
  for (size_t i = 0; i < n; ++i) {
    auto request = std::make_unique<locd_msg_SessionRequest>();
    std::memset(request.get(), 0, sizeof(locd_msg_SessionRequest));
    dds::copy_string(request->robot_id, plan.ids[i]);
    request->request_id = request_id;
    request->action = locd_msg_SESSION_START;
    dds::borrow_text(request->config_yaml, scenario.localizer.config_text, topics::kMaxConfigYamlBytes);
    groups[i / kRobotsPerWriter]->requests.write(*request);
  }
  if (!wait_all(plan, options, seen, [&](const SessionStatus& s) { return s.state == "running" && s.request_id == request_id; },
                "have a running session")) {
    return 2;
  }
  const double sessions_started_s = std::chrono::duration<double>(Clock::now() - start_requests).count();
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    origin_ns = wall_ns() + 500'000'000;  // every initial pose is held before the first message is due
  }
  for (size_t i = 0; i < n; ++i) {
    PoseEstimate pose = plan.run_of(i).initial_pose;
    pose.header.stamp_ns = origin_ns;
    dds::write(groups[i / kRobotsPerWriter]->initial_poses, plan.ids[i], pose);
  }
  const int64_t t_origin = origin_ns;
  if (!wait_all(plan, options, seen, [&](const SessionStatus& s) { return s.initial_pose_stamp_ns == t_origin; },
                "had their initial pose taken")) {
    return 2;
  }
  log << "locsim fleet: " << n << " robots running on domain " << options.domain_id << " (sessions started in "
      << std::fixed << std::setprecision(2) << sessions_started_s << " s); driving " << plan.duration << " s at rate "
      << options.rate << std::defaultfloat << std::endl;

  while (wall_ns() < t_origin) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const ProcessSample before = sample_servers(options.server_pids);
  const Drive drive = drive_fleet(plan, options, t_origin, groups, seen, log);
  const ProcessSample after = sample_servers(options.server_pids);
  std::this_thread::sleep_for(kDrain);
  // The servers' counters: statuses come once per status period.
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));

  std::lock_guard<std::mutex> lock(seen.mutex);
  const Json out = fleet_report(scenario, options, plan, seen, drive, sessions_started_s, before_sessions, before, after);
  if (options.json) {
    std::cout << out.dump() << std::endl;
  } else {
    std::cout << out.dump(2) << std::endl;
  }
  if (!options.plot_file.empty()) {
    write_plot(options.plot_file, seen.per_second, n);
    (options.json ? std::cerr : std::cout) << "plot: " << options.plot_file << std::endl;
  }
  return 0;
}

}  // namespace locd::sim
