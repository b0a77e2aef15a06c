// The locd executable itself: --help, --check-config (exit 0/1 with the error), a boot session
// that runs with no client, ServerInfo, the initial pose topic, a plugin switch over DDS, and a
// clean exit on SIGINT; what locd announces in participant discovery. Each DDS TEST has its own
// domain id (60-69, 208).
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include "child_process.hpp"
#include "locd/dds/convert.hpp"
#include "locd/dds/topics.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::dds::QosProfile;
using locd::test::ChildProcess;

constexpr auto kTimeout = 20s;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "'" << (part) << "' not in: " << (text)

std::string locd_path() { return locd::test::binary_dir() + "/bin/locd"; }

class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  fs::path write(const std::string& file, const std::string& text) const {
    std::ofstream(path_ / file) << text;
    return path_ / file;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string base_config(int domain) {
  return "domain_id: " + std::to_string(domain) + "\nplugin_directories: [" + locd::test::plugin_dir() + ", " +
         LOCD_BROKEN_PLUGIN_DIR + "]\nmap_directories: [" + locd::test::source_dir() + "/config/maps]\n" +
         "status_period_s: 0.2\n";
}

// Runs locd to completion and returns {exit code, output}.
std::pair<int, std::string> run_locd(const TempDir& dir, const std::vector<std::string>& args) {
  ChildProcess locd(locd_path(), args, (dir.path() / "run.log").string());
  const int code = locd.wait(30s);
  return {code, locd.output()};
}

TEST(ServerCli, HelpPrintsUsage) {
  TempDir dir("locd_cli_help");
  const auto [code, output] = run_locd(dir, {"--help"});
  EXPECT_EQ(code, 0);
  EXPECT_CONTAINS(output, "locd --config FILE");
  EXPECT_CONTAINS(output, "--check-config FILE");
  EXPECT_CONTAINS(output, "--plugin-dir DIR");
}

TEST(ServerCli, BadArgumentsExitNonZeroNamingTheOption) {
  TempDir dir("locd_cli_args");
  auto [code, output] = run_locd(dir, {"--config"});
  EXPECT_EQ(code, 2);
  EXPECT_CONTAINS(output, "option --config needs a value");
  std::tie(code, output) = run_locd(dir, {"--check-config", "x.yaml", "--domain", "400"});
  EXPECT_EQ(code, 2);
  EXPECT_CONTAINS(output, "--domain '400' is not allowed; expected an integer in [0, 232]");
}

TEST(ServerCli, CheckConfigAcceptsAGoodConfigWithABootSession) {
  TempDir dir("locd_cli_check_good");
  dir.write("robot.yaml", "plugin: fixture_odometry\nparams: {position_stddev: 0.3}\n");
  const auto config = dir.write("locd.yaml", base_config(0) + "sessions:\n  - {robot_id: r1, config_file: robot.yaml}\n");
  const auto [code, output] = run_locd(dir, {"--check-config", config.string()});
  EXPECT_EQ(code, 0) << output;
  EXPECT_CONTAINS(output, "OK: " + config.string());
  EXPECT_CONTAINS(output, "fixture_odometry");
  EXPECT_CONTAINS(output, "boot sessions: 1");
  EXPECT_CONTAINS(output, "warning: plugin refused: ");  // the broken fixtures next to it
}

TEST(ServerCli, PluginDirOptionAddsADirectory) {
  TempDir dir("locd_cli_plugin_dir");
  const auto config = dir.write("locd.yaml", "domain_id: 3\n");
  const auto [code, output] =
      run_locd(dir, {"--check-config", config.string(), "--plugin-dir", LOCD_BROKEN_PLUGIN_DIR, "--domain", "9"});
  EXPECT_EQ(code, 0) << output;
  EXPECT_CONTAINS(output, "domain 9, plugins: broken_configure_throws, broken_factory_throws, faulty, fixture_odometry");
}

TEST(ServerCli, CheckConfigNamesEachError) {
  TempDir dir("locd_cli_check_bad");
  auto config = dir.write("bad_key.yaml", base_config(0) + "queue_depth: 0\n");
  auto [code, output] = run_locd(dir, {"--check-config", config.string()});
  EXPECT_EQ(code, 1);
  EXPECT_CONTAINS(output, "parameter 'queue_depth' (line 5, column 14) = 0 is out of range; allowed: [1, 10000]");

  config = dir.write("missing_dir.yaml", "plugin_directories: [no_such_plugins]\n");
  std::tie(code, output) = run_locd(dir, {"--check-config", config.string()});
  EXPECT_EQ(code, 1);
  EXPECT_CONTAINS(output, "plugin directory '" + (dir.path() / "no_such_plugins").string() + "' does not exist");

  config = dir.write("bad_boot.yaml", base_config(0) + "sessions:\n  - {robot_id: r1, config: {plugin: fixture_odometry, "
                                                       "params: {position_stddev: -2}}}\n");
  std::tie(code, output) = run_locd(dir, {"--check-config", config.string()});
  EXPECT_EQ(code, 1);
  EXPECT_CONTAINS(output, "boot session for robot 'r1'");
  EXPECT_CONTAINS(output, "parameter 'fixture_odometry.position_stddev'");
  EXPECT_CONTAINS(output, "allowed: (0, inf]");

  if (fs::exists(fs::path(locd::test::plugin_dir()) / "liblocd_feature_ekf.so")) {
    config = dir.write("bad_map.yaml", base_config(0) + "sessions:\n  - {robot_id: r1, config: {plugin: feature_ekf, "
                                                        "params: {map: ../maps/corridor.yaml}}}\n");
    std::tie(code, output) = run_locd(dir, {"--check-config", config.string()});
    EXPECT_EQ(code, 1);
    EXPECT_CONTAINS(output, "map file '../maps/corridor.yaml' contains '..'");
  }
}

// A robot-side participant for the DDS tests: its endpoints in the robot's partition.
class Robot {
 public:
  Robot(int domain, const std::string& robot_id) : participant_(domain) {
    const locd::dds::Partitions own{locd::topics::robot_partition(robot_id)};
    requests_ = locd::dds::Writer<locd_msg_SessionRequest>(participant_, locd::topics::kSessionRequest, QosProfile::kState,
                                                           8, own);
    odometry_ = locd::dds::Writer<locd_msg_Odometry>(participant_, locd::topics::kOdometry, QosProfile::kSensor, 64, own);
    initial_pose_ = locd::dds::Writer<locd_msg_InitialPose>(participant_, locd::topics::kInitialPose, QosProfile::kState,
                                                            8, own);
    statuses_ = locd::dds::Reader<locd_msg_SessionStatus>(participant_, locd::topics::kSessionStatus, QosProfile::kState,
                                                          [this](const locd_msg_SessionStatus& m) {
                                                            std::lock_guard<std::mutex> lock(mutex_);
                                                            statuses_seen_.push_back(m);
                                                          },
                                                          8, own);
    poses_ = locd::dds::Reader<locd_msg_PoseEstimate>(participant_, locd::topics::kPose, QosProfile::kPose,
                                                      [this](const locd_msg_PoseEstimate& m) {
                                                        std::lock_guard<std::mutex> lock(mutex_);
                                                        poses_seen_.push_back(m);
                                                      },
                                                      8, own);
    info_ = locd::dds::Reader<locd_msg_ServerInfo>(participant_, locd::topics::kServerInfo, QosProfile::kState,
                                                   [this](const locd_msg_ServerInfo& m) {
                                                     std::lock_guard<std::mutex> lock(mutex_);
                                                     server_id_ = locd::dds::to_string(m.server_id);
                                                     plugins_.clear();
                                                     for (uint32_t i = 0; i < m.plugins._length; ++i) {
                                                       plugins_.push_back(locd::dds::to_string(m.plugins._buffer[i].name));
                                                     }
                                                     rejected_ = m.rejected_plugins._length;
                                                   });
  }

  template <typename Pred>
  bool wait(Pred pred) {
    const auto deadline = std::chrono::steady_clock::now() + kTimeout;
    while (std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (pred()) return true;
      }
      std::this_thread::sleep_for(5ms);
    }
    return false;
  }
  bool connected() {
    // Output readers match the server's writers of this robot once its session has begun.
    return wait([this] { return requests_.matched() > 0 && odometry_.matched() > 0 && initial_pose_.matched() > 0; });
  }
  void request(const std::string& robot, uint64_t id, const std::string& yaml) {
    auto sample = std::make_unique<locd_msg_SessionRequest>();
    std::memset(sample.get(), 0, sizeof(locd_msg_SessionRequest));
    locd::dds::copy_string(sample->robot_id, robot);
    sample->request_id = id;
    sample->action = locd_msg_SESSION_START;
    locd::dds::borrow_text(sample->config_yaml, yaml, locd::topics::kMaxConfigYamlBytes);
    requests_.write(*sample);
  }
  void send_odometry(const std::string& robot, int64_t stamp, double x) {
    locd::Odometry o;
    o.header = {stamp, "odom"};
    o.pose.translation() = Eigen::Vector3d(x, 0.0, 0.0);
    locd::dds::write(odometry_, robot, o);
  }
  void send_initial_pose(const std::string& robot, double x, double y) {
    locd::PoseEstimate p;
    p.header = {1, "map"};
    p.pose.translation() = Eigen::Vector3d(x, y, 0.0);
    locd::dds::write(initial_pose_, robot, p);
  }
  // Newest pose with this stamp, if any (call inside wait()).
  const locd_msg_PoseEstimate* pose_at(int64_t stamp) const {
    for (auto it = poses_seen_.rbegin(); it != poses_seen_.rend(); ++it) {
      if (it->header.stamp_ns == stamp) return &*it;
    }
    return nullptr;
  }
  const locd_msg_SessionStatus* status_of(const std::string& robot, uint64_t request_id) const {
    for (auto it = statuses_seen_.rbegin(); it != statuses_seen_.rend(); ++it) {
      if (locd::dds::to_string(it->robot_id) == robot && it->request_id == request_id &&
          it->state != locd_msg_STATE_STARTING) {
        return &*it;
      }
    }
    return nullptr;
  }

  std::string server_id_;
  std::vector<std::string> plugins_;
  uint32_t rejected_ = 0;
  std::vector<locd_msg_SessionStatus> statuses_seen_;
  std::vector<locd_msg_PoseEstimate> poses_seen_;

 private:
  std::mutex mutex_;
  locd::dds::Participant participant_;
  locd::dds::Writer<locd_msg_SessionRequest> requests_;
  locd::dds::Writer<locd_msg_Odometry> odometry_;
  locd::dds::Writer<locd_msg_InitialPose> initial_pose_;
  locd::dds::Reader<locd_msg_SessionStatus> statuses_;
  locd::dds::Reader<locd_msg_PoseEstimate> poses_;
  locd::dds::Reader<locd_msg_ServerInfo> info_;
};

TEST(ServerCli, BootSessionRunsWithoutAClientAndShutsDownCleanlyOnSigint) {
  TempDir dir("locd_cli_boot");
  const auto config = dir.write("locd.yaml", base_config(60) + "server_id: boot-test\nsessions:\n"
                                             "  - robot_id: booted\n"
                                             "    config: {plugin: fixture_odometry}\n"
                                             "    initial_pose: [3.0, 1.0, 0.0]\n");
  ChildProcess locd(locd_path(), {"--config", config.string()}, (dir.path() / "locd.log").string());
  Robot robot(60, "booted");
  ASSERT_TRUE(robot.connected()) << locd.output();

  ASSERT_TRUE(robot.wait([&] { return !robot.server_id_.empty(); })) << locd.output();
  EXPECT_EQ(robot.server_id_, "boot-test");
  // The four good fixtures of the broken-plugin folder, and every plugin built in this tree.
  size_t built = 0;
  for (const auto& entry : fs::directory_iterator(locd::test::plugin_dir())) built += entry.path().extension() == ".so";
  EXPECT_EQ(robot.plugins_.size(), 4u + built);
  EXPECT_EQ(robot.rejected_, 4u);

  // Running with nobody having asked: request_id 0, state running.
  ASSERT_TRUE(robot.wait([&] { return robot.status_of("booted", 0) != nullptr; })) << locd.output();
  EXPECT_EQ(robot.status_of("booted", 0)->state, locd_msg_STATE_RUNNING);

  // The boot initial pose (3, 1) anchors the odometry.
  robot.send_odometry("booted", 100, 0.5);
  ASSERT_TRUE(robot.wait([&] { return robot.pose_at(100) != nullptr; })) << locd.output();
  EXPECT_NEAR(robot.pose_at(100)->pose.position.x, 3.0, 1e-9);
  EXPECT_NEAR(robot.pose_at(100)->pose.position.y, 1.0, 1e-9);
  EXPECT_EQ(locd::dds::to_string(robot.pose_at(100)->plugin), "fixture_odometry");

  // The initial pose topic re-anchors it: odometry moves 1 m from there.
  // DDS orders samples per topic only: the status naming the pose's stamp says the plugin holds
  // it before the next odometry is sent. It counts as received and used (boot pose, odometry, pose).
  robot.send_initial_pose("booted", 7.0, -2.0);
  ASSERT_TRUE(robot.wait([&] { return robot.status_of("booted", 0)->initial_pose_stamp_ns == 1; })) << locd.output();
  EXPECT_EQ(robot.status_of("booted", 0)->received, 3u);
  EXPECT_EQ(robot.status_of("booted", 0)->used, 3u);
  robot.send_odometry("booted", 200, 1.5);
  robot.send_odometry("booted", 300, 2.5);
  ASSERT_TRUE(robot.wait([&] { return robot.pose_at(300) != nullptr; })) << locd.output();
  EXPECT_NEAR(robot.pose_at(300)->pose.position.x, 8.0, 1e-9);
  EXPECT_NEAR(robot.pose_at(300)->pose.position.y, -2.0, 1e-9);

  locd.signal(SIGINT);
  EXPECT_EQ(locd.wait(10s), 0);
  const std::string log = locd.output();
  EXPECT_CONTAINS(log, "info [booted] session started: plugin fixture_odometry");
  EXPECT_CONTAINS(log, "CYCLONEDDS_URI=");
  EXPECT_CONTAINS(log, "shutting down");
  EXPECT_CONTAINS(log, "info [server] stopped");
}

TEST(ServerCli, SwitchOverDdsHandsThePoseToTheNewPlugin) {
  TempDir dir("locd_cli_switch");
  const auto config = dir.write("locd.yaml", base_config(61));
  ChildProcess locd(locd_path(), {"--config", config.string()}, (dir.path() / "locd.log").string());
  Robot robot(61, "switcher");
  ASSERT_TRUE(robot.connected()) << locd.output();
  robot.request("switcher", 1, "plugin: fixture_odometry\nparams: {position_stddev: 0.1}\n");
  ASSERT_TRUE(robot.wait([&] { return robot.status_of("switcher", 1) != nullptr; })) << locd.output();
  robot.send_initial_pose("switcher", 5.0, 0.0);
  ASSERT_TRUE(robot.wait([&] { return robot.status_of("switcher", 1)->initial_pose_stamp_ns == 1; })) << locd.output();
  robot.send_odometry("switcher", 100, 0.0);
  ASSERT_TRUE(robot.wait([&] { return robot.pose_at(100) != nullptr; })) << locd.output();
  EXPECT_NEAR(robot.pose_at(100)->pose.position.x, 5.0, 1e-9);

  robot.request("switcher", 2, "plugin: fixture_odometry\nparams: {position_stddev: 0.4}\n");
  ASSERT_TRUE(robot.wait([&] { return robot.status_of("switcher", 2) != nullptr; })) << locd.output();
  robot.send_odometry("switcher", 200, 0.0);
  robot.send_odometry("switcher", 300, 1.0);
  ASSERT_TRUE(robot.wait([&] { return robot.pose_at(300) != nullptr; })) << locd.output();
  EXPECT_NEAR(robot.pose_at(300)->pose.position.x, 6.0, 1e-9);          // continues from x = 5
  EXPECT_NEAR(robot.pose_at(300)->covariance[0], 0.16, 1e-12);          // the new instance
  EXPECT_CONTAINS(locd.output(), "switched plugin fixture_odometry -> fixture_odometry (last pose handed over)");
}

}  // namespace

// What a listener on the network learns from participant discovery, which travels in clear even
// with DDS Security: locd's participant (and every participant of locd's DDS layer) announces no
// process name, pid or host name among its properties, as Cyclone does by default (issue 23).
// Read with Cyclone's own API, not locd's. The host name still travels in Cyclone's version
// information (README "Security").
TEST(ServerDiscovery, LocdAnnouncesNoProcessNamePidOrHostName) {
  constexpr int kDomain = 208;
  TempDir dir("locd_discovery");
  const auto config = dir.write("locd.yaml", base_config(kDomain) + "server_id: discovery-test\n");
  ChildProcess locd(locd_path(), {"--config", config.string()}, (dir.path() / "locd.log").string());
  const dds_entity_t listener = dds_create_participant(kDomain, nullptr, nullptr);
  ASSERT_GT(listener, 0);
  dds_guid_t own{};
  ASSERT_EQ(dds_get_guid(listener, &own), DDS_RETCODE_OK);
  const dds_entity_t reader = dds_create_reader(listener, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
  ASSERT_GT(reader, 0);
  // The other participants seen, each with the properties it announced.
  std::map<std::string, std::map<std::string, std::string>> seen;
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  bool default_listener_seen = false;
  while (std::chrono::steady_clock::now() < deadline && (seen.empty() || !default_listener_seen)) {
    void* samples[8] = {nullptr};
    dds_sample_info_t infos[8];
    const int n = dds_take(reader, samples, infos, 8, 8);
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[i]);
      std::map<std::string, std::string> properties;
      uint32_t count = 0;
      char** names = nullptr;
      if (p->qos != nullptr && dds_qget_propnames(p->qos, &count, &names)) {
        for (uint32_t k = 0; k < count; ++k) {
          char* value = nullptr;
          if (dds_qget_prop(p->qos, names[k], &value)) {
            properties[names[k]] = value;
            dds_free(value);
          }
          dds_free(names[k]);
        }
        dds_free(names);
      }
      if (std::memcmp(p->key.v, own.v, sizeof(own.v)) == 0) {
        // The listener's own data, with Cyclone's defaults: the check below can see them.
        default_listener_seen = properties.count("__Pid") == 1 && !properties["__Pid"].empty();
        continue;
      }
      seen[std::string(reinterpret_cast<const char*>(p->key.v), sizeof(p->key.v))] = properties;
    }
    if (n > 0) dds_return_loan(reader, samples, n);
    std::this_thread::sleep_for(50ms);
  }
  dds_delete(listener);
  ASSERT_TRUE(default_listener_seen) << "a participant with Cyclone's defaults announces its pid";
  ASSERT_FALSE(seen.empty()) << "locd's participant was not discovered: " << locd.output();
  for (const auto& [guid, properties] : seen) {
    for (const char* name : {"__ProcessName", "__Pid", "__Hostname"}) {
      const auto at = properties.find(name);
      EXPECT_TRUE(at == properties.end() || at->second.empty()) << name << " = '" << at->second << "'";
    }
  }
  locd.signal(SIGINT);
  EXPECT_EQ(locd.wait(10s), 0);
}
