// The icp_explorer plugin as the server loads it (dlopen from the plugin directory): parameter
// validation with clear messages, bad clouds (empty, above the limit, NaN, no intensity), the
// outputs of a scan (pose, diagnostics, map, exploration goal) and map saving into the configured
// directory under a generated name, read back with PCL.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <fstream>
#include <sstream>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "test_env.hpp"
#include "toy_world.hpp"

namespace fs = std::filesystem;

namespace {

std::shared_ptr<locd::PluginLibrary> library() {
  static auto lib = locd::PluginLibrary::open(fs::path(locd::test::plugin_dir()) / "liblocd_icp_explorer.so");
  return lib;
}

std::string toy_params(const std::string& extra_map_output = "") {
  return R"(
max_points: 50000
rejection: {max_range: 15.0}
exploration:
  origin: [-0.5, -0.5]
  size: [11.0, 5.0]
  rays: 60
  candidate_stride: 3
  done_threshold: 5.0
map_output: {publish_every_scans: 1, publish_voxel_size: 0.3)" + extra_map_output + "}\n";
}
const std::string kToyParams = toy_params();

locd::Params params(const std::string& text) { return locd::Params(YAML::Load(text), "icp_explorer"); }

struct Logged {
  std::vector<std::string> warnings;
};

locd::LocalizerPtr configured(const std::string& text, Logged* logged = nullptr, size_t max_cloud_points = 1'000'000,
                              const fs::path& output_directory = {}) {
  auto localizer = library()->create();
  locd::PluginContext context;
  context.output_directory = output_directory;
  context.robot_id = "robot/7";
  context.limits.max_cloud_points = max_cloud_points;
  if (logged)
    context.log = [logged](locd::LogLevel level, const std::string& m) {
      if (level == locd::LogLevel::kWarning) logged->warnings.push_back(m);
    };
  localizer->configure(context, params(text));
  return localizer;
}

locd::PointCloud toy_scan(const locd::Pose2& pose, uint64_t seed, bool with_intensity = true) {
  locd::sim::Scanner3DConfig config = locd::test::coarse_scanner();
  config.with_intensity = with_intensity;
  const locd::sim::Scanner3D scanner(config);
  std::mt19937_64 rng(seed);
  return scanner.scan(locd::test::two_rooms(), pose.to_isometry(), 0.0, 1'000'000'000, rng).cloud;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(IcpExplorerPlugin, DescriptorNamesItselfAndItsInputs) {
  const auto& d = library()->descriptor();
  EXPECT_STREQ(d.name, "icp_explorer");
  EXPECT_EQ(d.consumes, locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kPointCloud));
}

TEST(IcpExplorerPlugin, ShippedConfigIsValid) {
  std::ifstream in(locd::test::source_dir() + "/config/plugins/icp_explorer.yaml");
  std::stringstream text;
  text << in.rdbuf();
  const locd::PluginConfig config = locd::split_plugin_config(text.str(), "icp_explorer.yaml");
  EXPECT_EQ(config.plugin, "icp_explorer");
  auto plugin = library()->create();
  EXPECT_NO_THROW(plugin->configure(locd::PluginContext{}, config.params));
}

TEST(IcpExplorerPlugin, ConfigErrorsNameKeyValueAndAllowed) {
  auto plugin = library()->create();
  locd::PluginContext context;
  const std::string range = message_of([&] { plugin->configure(context, params("rejection: {intensity_threshold: 1.5}")); });
  EXPECT_NE(range.find("icp_explorer.rejection.intensity_threshold"), std::string::npos) << range;
  EXPECT_NE(range.find("1.5"), std::string::npos) << range;
  const std::string metric = message_of([&] { plugin->configure(context, params("icp: {metric: point_to_line}")); });
  EXPECT_NE(metric.find("point_to_plane"), std::string::npos) << metric;
  const std::string typo = message_of([&] { plugin->configure(context, params("scan_voxel: 0.3")); });
  EXPECT_NE(typo.find("scan_voxel"), std::string::npos) << typo;
  const std::string too_many = message_of([&] { plugin->configure(context, params("max_points: 2000000")); });
  EXPECT_NE(too_many.find("max_points"), std::string::npos) << too_many;
  // A directory to write into is the server's to give (PluginContext::output_directory), never the config's.
  const std::string path = message_of([&] { plugin->configure(context, params("map_output: {save_directory: /tmp}")); });
  EXPECT_NE(path.find("unknown parameter 'icp_explorer.map_output.save_directory'"), std::string::npos) << path;
  EXPECT_THROW(plugin->configure(context, params("exploration: {size: [100000, 100000]}")), locd::ConfigError);
}

TEST(IcpExplorerPlugin, BadCloudsAreRejectedOrCounted) {
  Logged logged;
  auto plugin = configured(kToyParams, &logged, 60000);
  // Empty clouds, clouds of NaN points only and intensity lists of the wrong size never reach the
  // plugin: the bridge refuses them (tests/sdk/validate_test.cpp). Its own limit, max_points:
  locd::PointCloud big;
  big.points.assign(50001, Eigen::Vector3f(1, 0, 0));
  const std::string limit = message_of([&] { plugin->update(big); });
  EXPECT_NE(limit.find("50001"), std::string::npos) << limit;
  EXPECT_NE(limit.find("50000"), std::string::npos) << limit;
  EXPECT_THROW(plugin->update(locd::Imu{}), locd::InputError);

  locd::PointCloud with_nan = toy_scan(locd::Pose2(3.0, 1.2, 0.0), 2);
  with_nan.points[0] = Eigen::Vector3f(NAN, 1, 1);
  with_nan.points[1] = Eigen::Vector3f(1, INFINITY, 1);
  auto result = plugin->update(with_nan);
  ASSERT_TRUE(result.estimate.has_value());
  auto value = [](const locd::UpdateResult& r, const std::string& name) {
    for (const auto& [n, v] : r.diagnostics.values)
      if (n == name) return v;
    return -1.0;
  };
  EXPECT_EQ(value(result, "non_finite_points"), 2.0);

  const auto no_intensity = toy_scan(locd::Pose2(3.5, 1.5, 0.1), 3, false);
  result = plugin->update(no_intensity);
  EXPECT_EQ(value(result, "clouds_without_intensity"), 1.0);
  ASSERT_EQ(logged.warnings.size(), 1u);
  EXPECT_NE(logged.warnings[0].find("rule (a)"), std::string::npos);
  EXPECT_EQ(value(result, "rejected_intensity"), 0.0);
  EXPECT_EQ(value(result, "registered"), 1.0);
}

TEST(IcpExplorerPlugin, ScansGivePoseMapAndExplorationGoal) {
  auto plugin = configured(kToyParams);
  locd::PoseEstimate start;
  start.pose = locd::Pose2(3.0, 1.2, 0.0).to_isometry();
  plugin->set_pose(start);
  locd::Odometry odom;
  odom.pose = locd::Pose2(0, 0, 0).to_isometry();
  plugin->update(odom);
  auto first = plugin->update(toy_scan(locd::Pose2(3.0, 1.2, 0.0), 4));
  ASSERT_TRUE(first.estimate && first.map_cloud && first.exploration_goal);
  EXPECT_FALSE(first.exploration_goal->done);
  EXPECT_EQ(first.map_cloud->header.frame_id, "map");
  EXPECT_GT(first.map_cloud->points.size(), 100u);
  EXPECT_EQ(first.map_cloud->intensity.size(), first.map_cloud->points.size());
  // Drive 0.8 m forward and turn 0.2 rad; odometry reports 0.3 m and 5 deg too little.
  const locd::Pose2 truth(3.8, 1.2, 0.2);
  odom.pose = locd::Pose2(0.5, 0.0, 0.2 - 5.0 * M_PI / 180).to_isometry();
  odom.header.stamp_ns = 2'000'000'000;
  plugin->update(odom);
  auto second = plugin->update(toy_scan(truth, 5));
  ASSERT_TRUE(second.estimate.has_value());
  EXPECT_LT((second.estimate->pose.translation() - truth.to_isometry().translation()).norm(), 0.03);
  EXPECT_NEAR(locd::yaw_of(second.estimate->pose.linear()), 0.2, 0.005);
  EXPECT_TRUE(second.estimate->covariance.allFinite());
  EXPECT_GT(second.estimate->covariance(0, 0), 0.0);
}

TEST(IcpExplorerPlugin, SavesTheMapOnlyIntoTheConfiguredDirectory) {
  auto disabled = configured(kToyParams);
  disabled->update(toy_scan(locd::Pose2(3.0, 1.2, 0.0), 6));
  const std::string off = message_of([&] { disabled->save_map(); });
  EXPECT_NE(off.find("output_directory in the server config"), std::string::npos) << off;

  const fs::path dir = fs::temp_directory_path() / ("icp_explorer_save_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const std::string format : {"pcd", "ply"}) {
    auto plugin = configured(toy_params(", save_format: " + format), nullptr, 1'000'000, fs::canonical(dir));
    EXPECT_THROW(plugin->save_map(), locd::InputError) << "nothing scanned yet";
    locd::PoseEstimate start;
    start.pose = locd::Pose2(3.0, 1.2, 0.0).to_isometry();
    plugin->set_pose(start);  // map frame = world frame
    plugin->update(toy_scan(locd::Pose2(3.0, 1.2, 0.0), 6));
    const fs::path file = plugin->save_map();
    EXPECT_EQ(file.parent_path(), fs::canonical(dir));
    EXPECT_EQ(file.extension(), "." + format);
    EXPECT_EQ(file.filename().string().rfind("robot_7_map_1scans_", 0), 0u) << file;
    pcl::PointCloud<pcl::PointXYZI> cloud;
    const int status = format == "pcd" ? pcl::io::loadPCDFile(file.string(), cloud) : pcl::io::loadPLYFile(file.string(), cloud);
    ASSERT_EQ(status, 0) << file;
    EXPECT_GT(cloud.size(), 1000u);
    bool inside = true;
    for (const auto& p : cloud) inside &= p.x > -0.5 && p.x < 10.5 && p.y > -0.5 && p.y < 4.5;
    EXPECT_TRUE(inside);
    const fs::path again = plugin->save_map();
    EXPECT_NE(again, file) << "a second save never overwrites the first";
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}
