// locview as people run it: locd localizes a simulated robot (locsim live) over loopback DDS, and
// the Foxglove WebSocket client from npm (@foxglove/ws-protocol) connects to locview, subscribes
// and decodes the robot's pose; a misbehaving client (garbage, unknown channels, 1000
// connections) gets clear errors and the view keeps serving. Plus the Foxglove conversions
// against values computed by hand.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <thread>

#include <unistd.h>

#include <sys/stat.h>

#include "access.hpp"
#include "child_process.hpp"
#include "foxglove.hpp"
#include "locd/dds/dds.hpp"
#include "node_client.hpp"
#include "test_env.hpp"
#include "test_server.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::test::ChildProcess;
using locd::test::TestServer;

namespace {

constexpr int kDomainView = 124;
constexpr int kDomainAbuse = 125;
constexpr int kDomainAccess = 128;

std::string binary(const std::string& name) { return locd::test::binary_dir() + "/bin/" + name; }

// Waits for locview's start line and returns its port (0 when it did not start).
int wait_for_port(ChildProcess& view) {
  const std::regex line("serving the fleet of DDS domain [0-9]+ on ws://127\\.0\\.0\\.1:([0-9]+)");
  for (int i = 0; i < 200; ++i) {
    std::smatch m;
    const std::string out = view.output();
    if (std::regex_search(out, m, line)) return std::stoi(m[1]);
    std::this_thread::sleep_for(50ms);
  }
  return 0;
}

struct Fleet {
  TestServer server;
  ChildProcess view;
  ChildProcess robot;
  int port = 0;
  Fleet(const std::string& name, int domain, std::vector<std::string> view_args, int robot_seconds)
      : server(name, domain),
        view(binary("locview"),
             [&] {
               std::vector<std::string> a = {"--domain", std::to_string(domain), "--port", "0", "--address", "127.0.0.1"};
               a.insert(a.end(), view_args.begin(), view_args.end());
               return a;
             }(),
             (server.dir() / "locview.log").string()),
        robot(binary("locsim"),
              {"live", locd::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain", std::to_string(domain),
               "--duration", std::to_string(robot_seconds), "--json", "--server-timeout", "20"},
              (server.dir() / "locsim.log").string()) {
    port = wait_for_port(view);
  }
  std::string url() const { return "ws://127.0.0.1:" + std::to_string(port); }
};

}  // namespace

TEST(Locview, FoxgloveClientDecodesThePoseOfARobotLocdLocalizes) {
  Fleet fleet("locview_pose", kDomainView, {}, 14);
  ASSERT_GT(fleet.port, 0) << fleet.view.output();
  std::this_thread::sleep_for(2s);  // the session starts, poses flow
  int exit_code = 0;
  const auto lines = locd::test::json_lines(locd::test::run_node("view_client.mjs", {fleet.url(), "corridor_bot", "6"}, exit_code));
  ASSERT_EQ(exit_code, 0) << fleet.view.output();
  ASSERT_FALSE(lines.empty());
  const auto& summary = lines.back()["summary"];
  EXPECT_EQ(summary["server"], "locview (locd fleet)");
  EXPECT_TRUE(summary["statuses"].empty()) << summary.dump();
  std::map<std::string, std::string> schema_of;
  for (const auto& c : summary["channels"]) {
    EXPECT_EQ(c["encoding"], "json");
    schema_of[c["topic"]] = c["schemaName"];
  }
  EXPECT_EQ(schema_of["/corridor_bot/pose"], "foxglove.PoseInFrame");
  EXPECT_EQ(schema_of["/corridor_bot/transforms"], "foxglove.FrameTransform");
  EXPECT_EQ(schema_of["/corridor_bot/scan"], "foxglove.PointCloud");
  EXPECT_EQ(schema_of["/corridor_bot/landmark_map"], "foxglove.SceneUpdate");
  EXPECT_EQ(schema_of["/corridor_bot/pose_covariance"], "foxglove.SceneUpdate");
  EXPECT_EQ(schema_of["/corridor_bot/status"], "locd.SessionStatus");
  // Every message of a Foxglove type is valid under Foxglove's own JSON schema.
  EXPECT_TRUE(summary["invalid"].empty()) << summary["invalid"].dump();
  for (const char* schema : {"foxglove.PoseInFrame", "foxglove.FrameTransform", "foxglove.PointCloud", "foxglove.SceneUpdate"}) {
    EXPECT_GT(summary["validated"].value(schema, 0), 0) << schema << " " << summary["validated"].dump();
  }

  // Every pose decoded is where the simulated truth at its stamp says the robot is.
  std::map<std::string, std::pair<double, double>> truth;
  std::vector<nlohmann::json> poses;
  bool running = false;
  for (const auto& l : lines) {
    if (!l.contains("topic")) continue;
    if (l["topic"] == "/corridor_bot/ground_truth") truth[l["stamp_ns"]] = {l["x"], l["y"]};
    if (l["topic"] == "/corridor_bot/pose") poses.push_back(l);
    if (l["topic"] == "/corridor_bot/status") running = running || l["state"] == "running";
  }
  EXPECT_TRUE(running);
  EXPECT_GT(poses.size(), 50u);  // 6 s of 25 Hz poses
  size_t compared = 0;
  for (const auto& p : poses) {
    EXPECT_EQ(p["frame_id"], "map");
    EXPECT_EQ(p["log_time"], p["stamp_ns"]);
    const auto t = truth.find(p["stamp_ns"]);
    if (t == truth.end()) continue;
    ++compared;
    EXPECT_LT(std::hypot(p["x"].get<double>() - t->second.first, p["y"].get<double>() - t->second.second), 0.2)
        << p.dump();
  }
  EXPECT_GT(compared, poses.size() / 2);
  EXPECT_TRUE(fleet.view.running());
}

TEST(Locview, GarbageAndAThousandConnectionsGetErrorsAndTheViewServesOn) {
  Fleet fleet("locview_abuse", kDomainAbuse, {"--max-clients", "8"}, 20);
  ASSERT_GT(fleet.port, 0) << fleet.view.output();
  std::this_thread::sleep_for(2s);
  int exit_code = 0;
  const auto lines = locd::test::json_lines(locd::test::run_node("view_abuse.mjs", {fleet.url(), "corridor_bot", "1000"}, exit_code));
  ASSERT_EQ(exit_code, 0);
  ASSERT_EQ(lines.size(), 1u);
  const auto& r = lines[0];
  std::string statuses;
  for (const auto& s : r["statuses"]) statuses += s.get<std::string>() + "\n";
  for (const char* expected :
       {"message is not JSON: 'this is not json {'", "not a JSON object with a string 'op'",
        "op 'publishEverything\\x07' is not supported; locview serves subscribe and unsubscribe",
        "channel 999999 is not advertised (subscription 1)", "needs unsigned 32-bit 'id' and 'channelId'",
        "subscribe needs an array 'subscriptions'", "no subscription '12345' to unsubscribe",
        "binary messages from clients are not supported"}) {
    EXPECT_NE(statuses.find(expected), std::string::npos) << "missing: " << expected << "\ngot:\n" << statuses;
  }
  // Closed as too big (1009), or reset while the client was still sending it (1006).
  const int oversized = r["oversized_closed_with"];
  EXPECT_TRUE(oversized == 1009 || oversized == 1006) << oversized;
  EXPECT_LE(r["opened"].get<int>(), 8);
  EXPECT_EQ(r["opened"].get<int>() + r["refused"].get<int>(), 1000) << r.dump();
  EXPECT_EQ(r["after"]["server"], "locview (locd fleet)");
  EXPECT_GT(r["after"]["poses"].get<int>(), 10) << r.dump();
  EXPECT_TRUE(fleet.view.running());
  EXPECT_TRUE(fleet.server.process().running());
  EXPECT_NE(fleet.view.output().find("refused a client"), std::string::npos);
}

// Tokens bound to robots, over the real view: Foxglove's client library without a token, with a
// wrong one, with one in the URL and in the Authorization header, with one of another robot, and
// from a foreign web page.
TEST(Locview, ATokenLetsAClientSeeItsRobotsOnlyAndForeignPagesAreRefused) {
  const std::string all = "all-robots-token-0123456789", mine = "corridor-bot-token-0123456789",
                    other = "other-bot-token-0123456789";
  const fs::path tokens = fs::temp_directory_path() / ("locview_tokens_" + std::to_string(::getpid()));
  {
    std::ofstream out(tokens);
    out << "# locview tokens\n" << all << " *\n" << mine << " corridor_bot\n" << other << " other_bot,third_bot\n";
  }
  fs::permissions(tokens, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  Fleet fleet("locview_access", kDomainAccess, {"--tokens", tokens.string()}, 20);
  fs::remove(tokens);
  ASSERT_GT(fleet.port, 0) << fleet.view.output();
  std::this_thread::sleep_for(3s);  // the session starts, the robot's channels appear
  int exit_code = 0;
  const auto lines = locd::test::json_lines(
      locd::test::run_node("view_access.mjs", {fleet.url(), "corridor_bot", all, mine, other}, exit_code));
  ASSERT_EQ(exit_code, 0) << fleet.view.output();
  ASSERT_EQ(lines.size(), 1u);
  const auto& r = lines[0];
  const auto topics = [](const nlohmann::json& attempt) {
    std::vector<std::string> t;
    for (const auto& c : attempt["channels"]) t.push_back(c["topic"]);
    return t;
  };
  const auto has = [](const std::vector<std::string>& list, const std::string& topic) {
    return std::find(list.begin(), list.end(), topic) != list.end();
  };
  EXPECT_EQ(r["no_token"]["refused_status"], 401) << r.dump();
  EXPECT_NE(r["no_token"]["refused_body"].get<std::string>().find("no token"), std::string::npos);
  EXPECT_EQ(r["wrong_token"]["refused_status"], 401);
  EXPECT_NE(r["wrong_token"]["refused_body"].get<std::string>().find("not valid"), std::string::npos);
  // Every robot's token, in the URL (as the Foxglove app connects): the robot's channels, poses.
  EXPECT_TRUE(r["all_in_query"]["opened"]);
  EXPECT_TRUE(has(topics(r["all_in_query"]), "/corridor_bot/pose"));
  EXPECT_GT(r["all_in_query"]["poses"].get<int>(), 5) << r["all_in_query"].dump();
  // The robot's own token, in the header: the same.
  EXPECT_TRUE(has(topics(r["robot_in_header"]), "/corridor_bot/pose"));
  EXPECT_GT(r["robot_in_header"]["poses"].get<int>(), 5);
  // Another robot's token: admitted, shown none of corridor_bot's channels, and its subscription
  // to the pose channel's id (learned elsewhere) is refused.
  EXPECT_TRUE(r["other_robot"]["opened"]);
  EXPECT_TRUE(topics(r["other_robot"]).empty()) << r["other_robot"].dump();
  EXPECT_EQ(r["other_robot"]["poses"], 0);
  std::string statuses;
  for (const auto& m : r["other_robot"]["statuses"]) statuses += m.get<std::string>();
  EXPECT_NE(statuses.find("is not advertised"), std::string::npos) << statuses;
  // A page of another site, even with a valid token, is refused; Foxglove's own is let in.
  EXPECT_EQ(r["foreign_origin"]["refused_status"], 403);
  EXPECT_NE(r["foreign_origin"]["refused_body"].get<std::string>().find("https://attacker.example"), std::string::npos);
  EXPECT_TRUE(r["foxglove_origin"]["opened"]);
  EXPECT_NE(fleet.view.output().find("refused a client"), std::string::npos);
  EXPECT_EQ(fleet.view.output().find(all), std::string::npos) << "a token reached the log";
  EXPECT_TRUE(fleet.view.running());
}

TEST(Locview, ServingOtherHostsWithoutATokenIsRefusedAtStart) {
  ChildProcess view(binary("locview"), {"--domain", std::to_string(kDomainAccess), "--port", "0", "--address", "0.0.0.0"},
                    (fs::temp_directory_path() / ("locview_open_" + std::to_string(::getpid()) + ".log")).string());
  EXPECT_EQ(view.wait(30s), 1);
  EXPECT_NE(view.output().find("--address 0.0.0.0 serves other hosts, and no token was given"), std::string::npos)
      << view.output();
}

// ------------------------------------------------------------------------------ access rules

namespace {

fs::path tokens_file(const std::string& name, const std::string& text, fs::perms mode) {
  const fs::path file = fs::temp_directory_path() / ("locview_" + name + "_" + std::to_string(::getpid()));
  std::ofstream(file) << text;
  fs::permissions(file, mode, fs::perm_options::replace);
  return file;
}

std::string tokens_error(const std::string& text, fs::perms mode = fs::perms::owner_read | fs::perms::owner_write) {
  const fs::path file = tokens_file("bad", text, mode);
  std::string error;
  try {
    locd::view::read_tokens_file(file);
  } catch (const std::exception& e) {
    error = e.what();
  }
  fs::remove(file);
  return error;
}

}  // namespace

TEST(LocviewAccess, ATokensFileNamesTheLineAndWhatIsAllowed) {
  const std::string good = "abcdefghijklmnop-0123";
  EXPECT_NE(tokens_error(good + " *\n", fs::perms::owner_read | fs::perms::group_read).find("mode 0440"), std::string::npos);
  EXPECT_NE(tokens_error(good + " *\n", fs::perms::owner_read | fs::perms::others_read).find("chmod 600"), std::string::npos);
  EXPECT_NE(tokens_error("# nothing\n").find("holds no token"), std::string::npos);
  EXPECT_NE(tokens_error("short *\n").find("line 1: a token has 16 to 256 characters, this one 5"), std::string::npos);
  EXPECT_NE(tokens_error("\n" + good + "/x *\n").find("line 2: a token holds only A-Z a-z 0-9 - . _ ~"), std::string::npos);
  EXPECT_NE(tokens_error(good + "\n").find("line 1: a token without robots"), std::string::npos);
  EXPECT_NE(tokens_error(good + " a, b\n").find("'b' after the robots"), std::string::npos);
  EXPECT_NE(tokens_error(good + " a\n" + good + " b\n").find("line 2: the token of an earlier line again"), std::string::npos);
  EXPECT_NE(tokens_error(good + " good,bad/robot\n").find("line 1: robot_id 'bad/robot' contains '/'"), std::string::npos);
  EXPECT_EQ(tokens_error(good + " *\n"), "");

  const fs::path file = tokens_file("good", "# fleet\n" + good + " a,b\n" + good + "X *\n",
                                    fs::perms::owner_read | fs::perms::owner_write);
  const auto grants = locd::view::read_tokens_file(file);
  fs::remove(file);
  ASSERT_EQ(grants.size(), 2u);
  EXPECT_TRUE(grants[0].sees("a"));
  EXPECT_TRUE(grants[0].sees("b"));
  EXPECT_FALSE(grants[0].sees("c"));
  EXPECT_TRUE(grants[1].sees("c"));
}

TEST(LocviewAccess, AdmissionByHeaderOrQueryAndOrigin) {
  using locd::view::admit;
  locd::view::AccessPolicy open;
  EXPECT_TRUE(admit(open, "", "/", "").admitted);
  EXPECT_TRUE(admit(open, "", "/", "https://app.foxglove.dev").admitted);
  const auto foreign = admit(open, "", "/", "http://192.168.1.9:8080");
  EXPECT_FALSE(foreign.admitted);
  EXPECT_EQ(foreign.http_status, 403);
  open.allowed_origins = {"*"};
  EXPECT_TRUE(admit(open, "", "/", "http://192.168.1.9:8080").admitted);

  locd::view::AccessPolicy policy;
  policy.grants.push_back({"first-token-0123456789", false, {"a"}});
  policy.grants.push_back({"second-token-0123456789", true, {}});
  EXPECT_EQ(admit(policy, "", "/", "").http_status, 401);
  EXPECT_EQ(admit(policy, "Bearer first-token-012345678", "/", "").http_status, 401) << "a prefix is not the token";
  EXPECT_EQ(admit(policy, "Bearer first-token-01234567890", "/", "").http_status, 401) << "nor a longer one";
  EXPECT_EQ(admit(policy, "Basic first-token-0123456789", "/", "").http_status, 401);
  EXPECT_EQ(admit(policy, "", "/?token=" + std::string(10000, 'a'), "").http_status, 401);
  const auto by_header = admit(policy, "Bearer first-token-0123456789", "/", "");
  ASSERT_TRUE(by_header.admitted);
  EXPECT_EQ(by_header.grant, &policy.grants[0]);
  const auto by_query = admit(policy, "", "/?x=1&token=second-token-0123456789&y=2", "");
  ASSERT_TRUE(by_query.admitted);
  EXPECT_EQ(by_query.grant, &policy.grants[1]);
  EXPECT_EQ(admit(policy, "Bearer second-token-0123456789", "/", "https://attacker.example").http_status, 403)
      << "the origin is checked with a valid token too";
}

// ------------------------------------------------------------------------------ conversions

TEST(FoxgloveConversion, CovarianceEllipseHasTwoSigmaHalfAxesAlongTheEigenvectors) {
  locd_msg_PoseEstimate pose{};
  locd::dds::copy_string(pose.robot_id, "r1");
  pose.pose.position = {1.0, 2.0, 0.0};
  pose.pose.orientation.w = 1.0;
  // sigma 2 m along 30 degrees, 0.5 m across.
  const double a = M_PI / 6, s1 = 4.0, s2 = 0.25;
  pose.covariance[0] = s1 * std::cos(a) * std::cos(a) + s2 * std::sin(a) * std::sin(a);
  pose.covariance[7] = s1 * std::sin(a) * std::sin(a) + s2 * std::cos(a) * std::cos(a);
  pose.covariance[1] = pose.covariance[6] = (s1 - s2) * std::sin(a) * std::cos(a);
  const auto scene = locd::view::covariance_ellipse(pose);
  const auto& sphere = scene["entities"][0]["spheres"][0];
  EXPECT_NEAR(sphere["size"]["x"].get<double>(), 8.0, 1e-9);  // 4 sigma across the major axis
  EXPECT_NEAR(sphere["size"]["y"].get<double>(), 2.0, 1e-9);
  const double yaw = 2 * std::atan2(sphere["pose"]["orientation"]["z"].get<double>(),
                                    sphere["pose"]["orientation"]["w"].get<double>());
  EXPECT_NEAR(std::remainder(yaw - a, M_PI), 0.0, 1e-9);  // an ellipse is symmetric under half turns
  EXPECT_EQ(scene["entities"][0]["id"], "r1/covariance");
}

TEST(FoxgloveConversion, Base64AndScanReturns) {
  EXPECT_EQ(locd::view::base64("foobar", 6), "Zm9vYmFy");
  EXPECT_EQ(locd::view::base64("fooba", 5), "Zm9vYmE=");
  EXPECT_EQ(locd::view::base64("fo", 2), "Zm8=");
  locd_msg_LaserScan scan{};
  locd::dds::copy_string(scan.robot_id, "r1");
  scan.range_min = 0.1f;
  scan.range_max = 10.0f;
  scan.angle_min = 0.0f;
  scan.angle_increment = static_cast<float>(M_PI / 2);
  float ranges[3] = {1.0f, 50.0f, 2.0f};  // the middle beam has no return
  scan.ranges._buffer = ranges;
  scan.ranges._length = 3;
  const auto cloud = locd::view::laser_scan(scan);
  EXPECT_EQ(cloud["frame_id"], "r1/base_link");
  EXPECT_EQ(cloud["point_stride"], 12);
  const double third = 2.0 * static_cast<double>(scan.angle_increment);  // the third beam's angle
  const float expected[6] = {1.0f, 0.0f, 0.0f, static_cast<float>(2.0 * std::cos(third)),
                             static_cast<float>(2.0 * std::sin(third)), 0.0f};
  EXPECT_EQ(cloud["data"], locd::view::base64(expected, sizeof expected));
}

TEST(FoxgloveConversion, GridKeepsRowMajorCellsFromTheOrigin) {
  locd_msg_GridMap g{};
  locd::dds::copy_string(g.robot_id, "r1");
  locd::dds::copy_string(g.layer, "belief");
  g.resolution = 0.5;
  g.origin_x = -1.0;
  g.origin_y = 2.0;
  g.width = 3;
  g.height = 2;
  float cells[6] = {0, 1, 2, 3, 4, 5};
  g.cells._buffer = cells;
  g.cells._length = 6;
  const auto j = locd::view::grid(g);
  EXPECT_EQ(j["column_count"], 3);
  EXPECT_EQ(j["row_stride"], 12);
  EXPECT_EQ(j["fields"][0]["name"], "belief");
  EXPECT_EQ(j["fields"][0]["type"], 7);  // FLOAT32
  EXPECT_DOUBLE_EQ(j["pose"]["position"]["x"].get<double>(), -1.0);
  EXPECT_EQ(j["data"], locd::view::base64(cells, sizeof cells));
  EXPECT_NO_THROW(nlohmann::json::parse(locd::view::json_schema("foxglove.Grid")));
  EXPECT_EQ(nlohmann::json::parse(locd::view::json_schema("foxglove.Grid"))["properties"]["data"]["contentEncoding"], "base64");
}

TEST(FoxgloveConversion, EveryKindOfMessageIsValidUnderFoxglovesOwnSchema) {
  using namespace locd::view;
  locd_msg_PoseEstimate pose{};
  locd::dds::copy_string(pose.robot_id, "r1");
  pose.pose.orientation.w = 1.0;
  pose.covariance[0] = pose.covariance[7] = 0.04;
  locd_msg_Particle particle_buffer[2] = {{1, 2, 0.5, 0.5}, {1.1, 2, 0.4, 0.5}};
  locd_msg_Diagnostics diagnostics{};
  locd::dds::copy_string(diagnostics.robot_id, "r1");
  diagnostics.particles._buffer = particle_buffer;
  diagnostics.particles._length = 2;
  float ranges[2] = {1.0f, 2.0f}, intensities[2] = {10.0f, 20.0f};
  locd_msg_LaserScan scan{};
  locd::dds::copy_string(scan.robot_id, "r1");
  scan.range_max = 10.0f;
  scan.angle_increment = 0.1f;
  scan.sensor_pose.orientation.w = 1.0;
  scan.ranges._buffer = ranges;
  scan.ranges._length = 2;
  scan.intensities._buffer = intensities;
  scan.intensities._length = 2;
  float xyz[6] = {1, 2, 3, 4, 5, 6};
  locd_msg_PointCloud cloud{};
  locd::dds::copy_string(cloud.robot_id, "r1");
  cloud.sensor_pose.orientation.w = 1.0;
  cloud.xyz._buffer = xyz;
  cloud.xyz._length = 6;
  locd_msg_PointCloudMap map{};
  locd::dds::copy_string(map.robot_id, "r1");
  map.xyz._buffer = xyz;
  map.xyz._length = 6;
  float cells[4] = {0, 0.5f, 1, NAN};
  locd_msg_GridMap g{};
  locd::dds::copy_string(g.robot_id, "r1");
  locd::dds::copy_string(g.layer, "belief");
  g.resolution = 0.1;
  g.width = g.height = 2;
  g.cells._buffer = cells;
  g.cells._length = 4;
  locd_msg_LandmarkFeature features[2] = {};
  locd::dds::copy_string(features[0].kind, "line");
  features[0].b = {1, 0, 0};
  locd::dds::copy_string(features[1].kind, "lamp");
  locd::dds::copy_string(features[1].id, "L7");
  locd_msg_LandmarkMap landmarks{};
  locd::dds::copy_string(landmarks.robot_id, "r1");
  landmarks.features._buffer = features;
  landmarks.features._length = 2;
  locd_msg_ExplorationGoal goal{};
  goal.pose.orientation.w = 1.0;
  const nlohmann::json messages = nlohmann::json::array({
      {{"schemaName", "foxglove.PoseInFrame"}, {"message", pose_in_frame(pose.header, pose.pose)}},
      {{"schemaName", "foxglove.FrameTransform"}, {"message", base_transform(pose)}},
      {{"schemaName", "foxglove.SceneUpdate"}, {"message", covariance_ellipse(pose)}},
      {{"schemaName", "foxglove.PosesInFrame"}, {"message", particles(diagnostics)}},
      {{"schemaName", "foxglove.PointCloud"}, {"message", laser_scan(scan)}},
      {{"schemaName", "foxglove.PointCloud"}, {"message", sensor_cloud(cloud)}},
      {{"schemaName", "foxglove.PointCloud"}, {"message", locd::view::map_cloud(map)}},
      {{"schemaName", "foxglove.Grid"}, {"message", grid(g)}},
      {{"schemaName", "foxglove.SceneUpdate"}, {"message", landmark_scene(landmarks)}},
      {{"schemaName", "foxglove.PoseInFrame"}, {"message", exploration_goal(goal)}},
  });
  const fs::path file = fs::temp_directory_path() / ("foxglove_messages_" + std::to_string(::getpid()) + ".json");
  std::ofstream(file) << messages.dump();
  int exit_code = 0;
  const auto out = locd::test::json_lines(locd::test::run_node("validate_foxglove.mjs", {file.string()}, exit_code));
  fs::remove(file);
  ASSERT_EQ(exit_code, 0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0]["invalid"].empty()) << out[0].dump();
  int validated = 0;
  for (const auto& [name, count] : out[0]["validated"].items()) validated += count.get<int>();
  EXPECT_EQ(validated, 10) << out[0].dump();
  // And the schemas locview advertises name the same required fields as Foxglove's.
  EXPECT_NE(json_schema("foxglove.SceneUpdate").find("\"models\""), std::string::npos);
}
