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

namespace {
double diagnostic(const locd::UpdateResult& r, const std::string& name) {
  for (const auto& [n, v] : r.diagnostics.values)
    if (n == name) return v;
  return -1.0;
}

// Two scans of the toy world, the second 0.8 m on with odometry 0.3 m and 5 degrees short, the
// intensities multiplied by `gain`.
std::vector<locd::UpdateResult> two_scans(locd::Localizer& plugin, float gain) {
  locd::PoseEstimate start;
  start.pose = locd::Pose2(3.0, 1.2, 0.0).to_isometry();
  plugin.set_pose(start);
  locd::Odometry odom;
  odom.pose = locd::Pose2(0, 0, 0).to_isometry();
  plugin.update(odom);
  std::vector<locd::UpdateResult> out;
  auto first = toy_scan(locd::Pose2(3.0, 1.2, 0.0), 4);
  for (float& i : first.intensity) i *= gain;
  out.push_back(plugin.update(first));
  odom.pose = locd::Pose2(0.5, 0.0, 0.2 - 5.0 * M_PI / 180).to_isometry();
  odom.header.stamp_ns = 2'000'000'000;
  plugin.update(odom);
  auto second = toy_scan(locd::Pose2(3.8, 1.2, 0.2), 5);
  for (float& i : second.intensity) i *= gain;
  out.push_back(plugin.update(second));
  return out;
}
}  // namespace

// Raw 0-255 intensities: the scale is estimated (auto, the default) or configured, and the
// registration is the same as on a 0-1 scale; with the scale forced to 1, rule (a) rejects most pairs.
TEST(IcpExplorerPlugin, IntensityScaleIsEstimatedOrConfigured) {
  auto unit = configured(kToyParams);
  const auto reference = two_scans(*unit, 1.0f);
  EXPECT_EQ(diagnostic(reference[1], "intensity_scale"), 1.0);
  for (const std::string scale : {"auto", "255"}) {
    auto raw = configured(kToyParams + "intensity_scale: " + scale + "\n");
    const auto results = two_scans(*raw, 215.0f);  // the KITTI pair's range, under a 255 full scale
    EXPECT_EQ(diagnostic(results[1], "intensity_scale"), 255.0) << scale;
    ASSERT_TRUE(results[1].estimate && reference[1].estimate);
    EXPECT_LT((results[1].estimate->pose.translation() - reference[1].estimate->pose.translation()).norm(), 0.01) << scale;
    EXPECT_LT(diagnostic(results[1], "rejected_intensity"), 0.05 * diagnostic(results[1], "correspondences")) << scale;
  }
  auto forced = configured(kToyParams + "intensity_scale: 1\n");
  const auto broken = two_scans(*forced, 215.0f);
  EXPECT_GT(diagnostic(broken[1], "rejected_intensity"), diagnostic(broken[1], "correspondences"));

  auto plugin = library()->create();
  for (const std::string bad : {"0", "-3", "bright"}) {
    const std::string m = message_of([&] { plugin->configure(locd::PluginContext{}, params("intensity_scale: " + bad)); });
    EXPECT_NE(m.find("icp_explorer.intensity_scale"), std::string::npos) << bad << ": " << m;
  }
}

// The localization state from the registration's criteria: the first scan anchors the map, a
// registered scan is tracking, a scan of another place where odometry says the robot is does not
// fit: lost, the odometry prediction published, the map unchanged.
TEST(IcpExplorerPlugin, LocalizationStateFollowsTheRegistration) {
  auto plugin = configured(kToyParams);
  const auto results = two_scans(*plugin, 1.0f);
  ASSERT_TRUE(results[0].localization && results[1].localization);
  EXPECT_EQ(results[0].localization->state, locd::LocalizationState::kTracking);
  EXPECT_NE(results[0].localization->reason.find("first scan"), std::string::npos);
  EXPECT_EQ(results[1].localization->state, locd::LocalizationState::kTracking) << results[1].localization->reason;
  EXPECT_EQ(diagnostic(results[1], "converged"), 1.0);
  const double model_points = diagnostic(results[1], "model_points");

  // An open hall with two crates where the two rooms have free space: nothing like them.
  std::vector<locd::sim::SurfaceBox> hall{
      {Eigen::AlignedBox3d(Eigen::Vector3d(-20, -20, -0.2), Eigen::Vector3d(20, 20, 0)), 0.5f, "floor"},
      {Eigen::AlignedBox3d(Eigen::Vector3d(3.5, 1.8, 0), Eigen::Vector3d(3.8, 2.4, 1.0)), 0.5f, "crate"},
      {Eigen::AlignedBox3d(Eigen::Vector3d(2.5, 0.8, 0), Eigen::Vector3d(3.5, 1.0, 2.0)), 0.5f, "crate"}};
  const locd::sim::IndoorWorld hall_world(std::move(hall), {});
  const locd::sim::Scanner3D scanner(locd::test::coarse_scanner());
  std::mt19937_64 rng(9);
  locd::Odometry odom;
  odom.pose = locd::Pose2(0.9, 0.0, 0.2).to_isometry();
  odom.header.stamp_ns = 3'000'000'000;
  plugin->update(odom);
  const auto lost = plugin->update(scanner.scan(hall_world, locd::Pose2(4.2, 1.3, 0.2).to_isometry(), 0.0, 3'000'000'000, rng).cloud);
  ASSERT_TRUE(lost.localization && lost.estimate);
  EXPECT_EQ(lost.localization->state, locd::LocalizationState::kLost)
      << lost.localization->reason << "; inliers " << diagnostic(lost, "inlier_share") << ", degenerate "
      << diagnostic(lost, "degenerate_directions");
  EXPECT_NE(lost.localization->reason.find("does not fit"), std::string::npos) << lost.localization->reason;
  EXPECT_EQ(diagnostic(lost, "added_to_model"), 0.0);
  EXPECT_EQ(diagnostic(lost, "model_points"), model_points);
  // The prediction: the second scan's pose moved as odometry moved since it.
  const Eigen::Isometry3d odom_then = locd::Pose2(0.5, 0.0, 0.2 - 5.0 * M_PI / 180).to_isometry();
  const Eigen::Isometry3d predicted = results[1].estimate->pose * odom_then.inverse() * odom.pose;
  EXPECT_LT((lost.estimate->pose.translation() - predicted.translation()).norm(), 1e-6);
  // Its covariance is the prior's: at least one odometry leg's (0.5 m / sqrt(3)) in x and y.
  EXPECT_GT(lost.estimate->covariance(0, 0), 0.08);
}
