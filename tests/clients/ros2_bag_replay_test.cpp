// ROS 2 bags replayed as users run it (issue 21), every program a child process over loopback
// DDS: a simulated robot's run (locsim run on the corridor grid, grid_mcl) is written as a ROS 2
// MCAP bag by an independent writer (tests/node/write_ros2_bag.mjs: npm @mcap/core and
// @foxglove/rosmsg2-serialization; /scan, /odom, /tf, /tf_static, ground truth as TUM), then
// `locsim replay BAG --config grid_mcl.yaml` feeds it into a running locd and scores the poses
// against the truth. Bad bags and references are refused before anything reaches the server,
// with messages naming the file, the message or line and the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "child_process.hpp"
#include "node_client.hpp"
#include "test_env.hpp"
#include "test_server.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::test::ChildProcess;
using locd::test::TestServer;
using Json = nlohmann::json;

namespace {

constexpr int kDomainReplay = 213;
constexpr int kDomainBadInput = 214;

std::string binary(const std::string& name) { return locd::test::binary_dir() + "/bin/" + name; }
std::string grid_mcl_config() { return locd::test::source_dir() + "/config/plugins/grid_mcl.yaml"; }
std::string maps() { return locd::test::source_dir() + "/config/maps"; }

// The simulated run and the bags written from it, once for the suite.
class Ros2BagReplay : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::random_device random;
    dir_ = fs::temp_directory_path() / ("ros2_bag_replay_" + std::to_string(random()));
    fs::create_directories(dir_);
    ChildProcess run(binary("locsim"), {"run", locd::test::source_dir() + "/config/scenarios/corridor_grid.yaml", "--duration",
                                        "20", "--seed", "3", "--mcap", (dir_ / "sim.mcap").string(), "--plugin-dir",
                                        locd::test::plugin_dir()},
                     (dir_ / "run.log").string());
    ASSERT_EQ(run.wait(120s), 0) << run.output();
    write_bag("bag.mcap", "ref.tum", {"--compression", "zstd"});
    write_bag("plain.mcap", "plain.tum", {"--compression", "none"});
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static void write_bag(const std::string& bag, const std::string& tum, std::vector<std::string> extra) {
    std::vector<std::string> args{(dir_ / "sim.mcap").string(), (dir_ / bag).string(), (dir_ / tum).string()};
    args.insert(args.end(), extra.begin(), extra.end());
    int exit_code = 0;
    const auto lines = locd::test::json_lines(locd::test::run_node("write_ros2_bag.mjs", args, exit_code));
    ASSERT_EQ(exit_code, 0);
    ASSERT_EQ(lines.size(), 1u);
    ASSERT_TRUE(lines[0]["ok"].get<bool>()) << lines[0].dump();
    ASSERT_EQ(lines[0]["counts"]["/tf_static"], 1) << lines[0].dump();
    ASSERT_GT(lines[0]["counts"].value("/scan", 0) + lines[0]["counts"].value("/front_scan", 0), 150) << lines[0].dump();
  }

  static fs::path file(const std::string& name) { return dir_ / name; }

  // locsim replay with `args` after the bag; its exit code, output and (with --json) its JSON.
  struct Result {
    int exit_code = -1;
    std::string output;
    Json json;
  };
  static Result replay(const std::string& bag, std::vector<std::string> args, const std::string& log) {
    std::vector<std::string> all{"replay", file(bag).string(), "--config", grid_mcl_config()};
    all.insert(all.end(), args.begin(), args.end());
    ChildProcess p(binary("locsim"), all, file(log).string());
    Result r;
    r.exit_code = p.wait(180s);
    r.output = p.output();
    const size_t at = r.output.rfind("{\"file\"");
    if (at != std::string::npos) r.json = Json::parse(r.output.substr(at, r.output.find('\n', at) - at));
    return r;
  }

  static fs::path dir_;
};
fs::path Ros2BagReplay::dir_;

void expect_contains(const std::string& text, const std::vector<std::string>& parts) {
  for (const auto& part : parts) EXPECT_NE(text.find(part), std::string::npos) << "'" << part << "' not in: " << text;
}

}  // namespace

TEST_F(Ros2BagReplay, BagIntoRunningLocdTracksTheTruth) {
  TestServer server("ros2_bag", kDomainReplay);
  // As fast as the session keeps up: each scan waits for its pose, nothing is dropped.
  const Result r = replay("bag.mcap", {"--domain", std::to_string(kDomainReplay), "--fast", "--initial-pose", "reference",
                                       "--reference", file("ref.tum").string(), "--json", "--server-timeout", "30"},
                          "into.log");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json& j = r.json;
  EXPECT_EQ(j["kind"], "ros2_bag");
  EXPECT_EQ(j["mode"], "dds");
  EXPECT_EQ(j["plugin"], "grid_mcl");
  EXPECT_EQ(j["topics"]["/scan"]["mapped_as"], "scan");
  EXPECT_EQ(j["topics"]["/scan"]["type"], "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(j["replayed"], j["measurements"]);
  EXPECT_EQ(j["transforms"], j["topics"]["/tf"]["messages"].get<int>() + 1);
  EXPECT_EQ(j["rejected"], 0) << j.dump();
  EXPECT_EQ(j["dropped"], 0) << j.dump();
  EXPECT_EQ(j["scans_without_pose"], 0) << j.dump();
  // A pose per scan at least, every one inside the reference.
  EXPECT_GE(j["poses"].get<int>(), j["topics"]["/scan"]["messages"].get<int>()) << j.dump();
  EXPECT_EQ(j["ape"]["not_covered"], 0) << j.dump();
  // grid_mcl on the corridor grid from the true start: centimetres (offline 0.03 m RMSE at seeds
  // 1-5, README); a filter that lost the robot is metres off.
  EXPECT_LT(j["ape"]["rmse_m"].get<double>(), 0.15) << j.dump();
  EXPECT_LT(j["ape"]["max_m"].get<double>(), 0.5) << j.dump();
  EXPECT_EQ(j["ape"]["share_over_0_5_m"], 0.0) << j.dump();
  EXPECT_LT(j["ape"]["heading_rmse_deg"].get<double>(), 3.0) << j.dump();
  EXPECT_GE(j["rpe"]["pairs"].get<int>(), j["poses"].get<int>() - 1) << j.dump();
  EXPECT_LT(j["rpe"]["rmse_m"].get<double>(), 0.05) << j.dump();
}

TEST_F(Ros2BagReplay, CompressedAndPlainChunksReplayTheSame) {
  // Offline (no DDS): the same arithmetic in the same order, so zstd and uncompressed chunks give
  // the same bits; a renamed bag maps by --topic; a late /tf_static changes nothing.
  const Result zstd = replay("bag.mcap", {"--offline", "--plugin-dir", locd::test::plugin_dir(), "--map-dir", maps(),
                                          "--initial-pose", "reference", "--reference", file("ref.tum").string(), "--json"},
                             "zstd.log");
  const Result plain = replay("plain.mcap", {"--offline", "--plugin-dir", locd::test::plugin_dir(), "--map-dir", maps(),
                                             "--initial-pose", "reference", "--reference", file("plain.tum").string(), "--json"},
                              "plain.log");
  ASSERT_EQ(zstd.exit_code, 0) << zstd.output;
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(zstd.json["ape"], plain.json["ape"]);
  EXPECT_LT(zstd.json["ape"]["rmse_m"].get<double>(), 0.15) << zstd.json.dump();

  write_bag("renamed.mcap", "renamed.tum", {"--variant", "renamed"});
  const Result renamed = replay("renamed.mcap", {"--offline", "--plugin-dir", locd::test::plugin_dir(), "--map-dir", maps(),
                                                 "--topic", "scan=/front_scan", "--topic", "odometry=wheel_odom",
                                                 "--initial-pose", "reference", "--reference", file("ref.tum").string(), "--json"},
                                "renamed_ok.log");
  ASSERT_EQ(renamed.exit_code, 0) << renamed.output;
  EXPECT_EQ(renamed.json["ape"], zstd.json["ape"]);
  // The same mapping as a ros2: section, as a ROS 2 robot's session config has it.
  std::ofstream(file("topics.yaml")) << "ros2:\n  topics:\n    scan: /front_scan\n    odometry: wheel_odom\n";
  const Result mapped = replay("renamed.mcap", {"--offline", "--plugin-dir", locd::test::plugin_dir(), "--map-dir", maps(),
                                                "--topics", file("topics.yaml").string(), "--initial-pose", "reference",
                                                "--reference", file("ref.tum").string(), "--json"},
                               "renamed_topics.log");
  ASSERT_EQ(mapped.exit_code, 0) << mapped.output;
  EXPECT_EQ(mapped.json["ape"], zstd.json["ape"]);
  EXPECT_EQ(mapped.json["topics"]["/front_scan"]["mapped_as"], "scan");

  // /tf_static recorded after the first scans: static transforms hold at any time.
  write_bag("late_static.mcap", "late_static.tum", {"--variant", "late-static"});
  const Result late = replay("late_static.mcap", {"--offline", "--plugin-dir", locd::test::plugin_dir(), "--map-dir", maps(),
                                                  "--initial-pose", "reference", "--reference", file("ref.tum").string(), "--json"},
                             "late_static.log");
  ASSERT_EQ(late.exit_code, 0) << late.output;
  EXPECT_EQ(late.json["ape"], zstd.json["ape"]);
}

TEST_F(Ros2BagReplay, BadBagsAndReferencesAreRefusedBeforeAnythingIsSent) {
  TestServer server("ros2_bag_bad", kDomainBadInput);
  const std::vector<std::string> into{"--domain", std::to_string(kDomainBadInput), "--fast", "--server-timeout", "30"};
  auto refused = [&](const std::string& bag, std::vector<std::string> args, const std::string& log,
                     const std::vector<std::string>& parts) {
    args.insert(args.end(), into.begin(), into.end());
    const Result r = replay(bag, args, log);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    expect_contains(r.output, parts);
  };

  // No mapped topic: the mapping and what the bag holds are named.
  write_bag("renamed.mcap", "renamed.tum", {"--variant", "renamed"});
  refused("renamed.mcap", {}, "renamed.log",
          {"renamed.mcap: no message on a mapped sensor topic", "scan /scan", "/front_scan (sensor_msgs/msg/LaserScan",
           "--topic KEY=NAME"});
  // An unknown message type on a mapped topic.
  write_bag("wrong_type.mcap", "wrong_type.tum", {"--variant", "wrong-type"});
  refused("wrong_type.mcap", {}, "wrong_type.log",
          {"wrong_type.mcap: message ", "topic '/scan'", "'my_msgs/msg/Scan' is not sensor_msgs/msg/LaserScan"});
  // A scan stamped before the one before it: the 20th scan, found late in the file.
  write_bag("backwards.mcap", "backwards.tum", {"--variant", "backwards"});
  refused("backwards.mcap", {}, "backwards.log",
          {"backwards.mcap: message ", "topic '/scan', sensor_msgs/msg/LaserScan", "header.stamp", "goes backwards"});
  // A file cut short.
  {
    std::ifstream in(file("plain.mcap"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(file("truncated.mcap"), std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 2 / 3));
  }
  refused("truncated.mcap", {}, "truncated.log", {"truncated.mcap: ", "truncated", "(after message ", "not replayed"});
  // A reference of another time.
  {
    std::ifstream in(file("ref.tum"));
    std::ofstream out(file("late.tum"));
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      out << "16" << line.substr(2) << "\n";  // t - 1e8 s
    }
  }
  refused("bag.mcap", {"--reference", file("late.tum").string()}, "late.log",
          {"late.tum", "does not overlap the bag", "bag.mcap"});
  // A reference line that does not parse.
  std::ofstream(file("broken.tum")) << "# t x y z qx qy qz qw\n1700000001.0 3 1 0 0 0 0 1\n1700000001.1 3 1 0 0 0 nan 1\n";
  refused("bag.mcap", {"--reference", file("broken.tum").string()}, "broken.log", {"broken.tum line 3", "field qz"});
  std::ofstream(file("short.tum")) << "1700000001.0 3 1 0\n";
  refused("bag.mcap", {"--reference", file("short.tum").string()}, "short.log", {"short.tum line 1", "field qx is missing"});

  // Nothing reached the server: no session was ever requested.
  std::this_thread::sleep_for(500ms);
  EXPECT_EQ(locd::test::read_text(server.dir() / "locd.log").find("robot1"), std::string::npos)
      << locd::test::read_text(server.dir() / "locd.log");
}
