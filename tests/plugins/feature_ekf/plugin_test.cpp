// The built plugin, loaded like the server loads it: configure, updates, errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "plugin_fixture.hpp"
#include "synthetic_scan.hpp"
#include "test_env.hpp"

using namespace locd;

namespace {

const char* kBuilding = R"(walls:
  - [[0, 0], [12, 0], [12, 8], [0, 8]]
  - [[6, 3], [6, 5]]
  - [[2, 6], [3.5, 6], [3.5, 7]]
closed: [true, false, false]
)";

class FeatureEkfPlugin : public test::FeatureEkfPluginFixture {
 protected:
  FeatureEkfPlugin() : FeatureEkfPluginFixture("r1", "building.yaml", kBuilding) {}
};

Odometry odometry_at(const Pose2& pose, int64_t stamp) {
  Odometry o;
  o.header.stamp_ns = stamp;
  o.pose = pose.to_isometry();
  return o;
}

}  // namespace

TEST_F(FeatureEkfPlugin, LoadsThroughTheCatalogAndLocalizes) {
  const auto library = catalog_.find("feature_ekf");
  ASSERT_NE(library, nullptr) << "plugin dir " << test::plugin_dir();
  // Laser model: odometry and scans; landmark models (issue 3): imu and detections.
  EXPECT_EQ(library->descriptor().consumes,
            kinds(MeasurementKind::kOdometry, MeasurementKind::kLaserScan, MeasurementKind::kImu,
                  MeasurementKind::kLandmarkDetections));

  LocalizerPtr localizer = configured("  map: building.yaml\n  gate_probability: 0.99\n");
  const UpdateResult outputs = localizer->initial_outputs();
  ASSERT_TRUE(outputs.landmark_map.has_value());
  EXPECT_EQ(outputs.landmark_map->size(), 7u + 5u + 4u);  // lines + corners + edges

  PoseEstimate initial;
  initial.pose = Pose2(6.1, 1.4, 0.03).to_isometry();
  initial.covariance = Matrix6d::Identity() * 0.04;
  localizer->set_pose(initial);

  std::mt19937_64 rng(4);
  Pose2 truth(6.0, 1.5, 0.0);
  Pose2 odometry;
  const FeatureMap2D map = test::map_from_walls(kBuilding);
  std::optional<UpdateResult> last;
  for (int k = 0; k < 50; ++k) {
    const int64_t stamp = k * 40'000'000LL;
    if (k > 0) {
      truth = truth * Pose2(0.02, 0.0, 0.005);
      odometry = odometry * Pose2(0.02, 0.0, 0.005);
    }
    EXPECT_FALSE(localizer->update(odometry_at(odometry, stamp)).estimate.has_value());
    LaserScan scan = test::ray_cast_scan(map.lines, truth, test::ScanGeometry{}, &rng);
    scan.header.stamp_ns = stamp;
    last = localizer->update(scan);
    ASSERT_TRUE(last->estimate.has_value());
    EXPECT_EQ(last->estimate->header.stamp_ns, stamp);
  }
  const Pose2 estimate = Pose2::from_isometry(last->estimate->pose);
  EXPECT_LT(std::hypot(estimate.x - truth.x, estimate.y - truth.y), 0.05);
  EXPECT_LT(std::abs(normalize_angle(estimate.theta - truth.theta)), 0.02);
  const Matrix6d& C = last->estimate->covariance;
  EXPECT_GT(C(0, 0), 0.0);
  EXPECT_GT(C(5, 5), 0.0);
  EXPECT_EQ(C(2, 2), 0.0);

  std::map<std::string, double> values(last->diagnostics.values.begin(), last->diagnostics.values.end());
  for (const char* key : {"lines_extracted", "corners_extracted", "edges_extracted", "lines_matched",
                          "corners_matched", "edges_matched", "mean_nis"}) {
    EXPECT_EQ(values.count(key), 1u) << key;
  }
  EXPECT_GE(values["lines_matched"], 2.0);
  ASSERT_FALSE(last->diagnostics.associations.empty());
  int associated = 0;
  for (const AssociationRecord& a : last->diagnostics.associations) associated += a.feature_id.empty() ? 0 : 1;
  EXPECT_GE(associated, 3);
}

TEST_F(FeatureEkfPlugin, BadConfigsNameTheKeyAndTheAllowedRange) {
  std::string message = config_error("  map: building.yaml\n  gate_probability: 1.5\n");
  EXPECT_NE(message.find("feature_ekf.gate_probability"), std::string::npos) << message;
  EXPECT_NE(message.find("(0, 1)"), std::string::npos) << message;

  message = config_error("  map: building.yaml\n  motion:\n    speed_stddev_floor: -0.1\n");
  EXPECT_NE(message.find("feature_ekf.motion.speed_stddev_floor"), std::string::npos) << message;
  EXPECT_NE(message.find("[0, "), std::string::npos) << message;

  message = config_error("  map: building.yaml\n  extraction:\n    range_stddev: 0\n");
  EXPECT_NE(message.find("feature_ekf.extraction.range_stddev"), std::string::npos) << message;

  message = config_error("  map: building.yaml\n  localization:\n    lost_window_scans: 30\n");
  EXPECT_NE(message.find("feature_ekf.localization.lost_window_scans"), std::string::npos) << message;
  EXPECT_NE(message.find("[1, 25]"), std::string::npos) << message;  // at most window_scans
  message = config_error("  map: building.yaml\n  global_search:\n    accept_agreement: 2\n");
  EXPECT_NE(message.find("feature_ekf.global_search.accept_agreement"), std::string::npos) << message;
  message = config_error("  map: building.yaml\n  scan_agreement:\n    beam: 5\n");
  EXPECT_NE(message.find("scan_agreement.beam"), std::string::npos) << message;

  message = config_error("  map: building.yaml\n  initial_pose: [1, 2]\n");
  EXPECT_NE(message.find("feature_ekf.initial_pose"), std::string::npos) << message;

  message = config_error("  map: building.yaml\n  gate_probabilty: 0.9\n");
  EXPECT_NE(message.find("gate_probabilty"), std::string::npos) << message;

  message = config_error("  gate_probability: 0.9\n");
  EXPECT_NE(message.find("feature_ekf.map"), std::string::npos) << message;

  message = config_error("  map: ../building.yaml\n");
  EXPECT_NE(message.find("no ConfigError"), 0u) << message;
  message = config_error("  map: /etc/passwd\n");
  EXPECT_NE(message.find("no ConfigError"), 0u) << message;
  message = config_error("  map: missing.yaml\n");
  EXPECT_NE(message.find("no ConfigError"), 0u) << message;
}

TEST_F(FeatureEkfPlugin, BadMeasurementsAreRejectedAndTheSessionGoesOn) {
  LocalizerPtr localizer = configured("  map: building.yaml\n  initial_pose: [6, 1.5, 0]\n");
  const FeatureMap2D map = test::map_from_walls(kBuilding);
  LaserScan scan = test::ray_cast_scan(map.lines, Pose2(6.0, 1.5, 0.0), test::ScanGeometry{});
  scan.header.stamp_ns = 1'000'000'000;

  // Empty, all-NaN, zero-increment and oversized scans, NaN odometry and stamps going backwards
  // never reach the plugin: the bridge and the session refuse them (tests/sdk/validate_test.cpp,
  // tests/server/session_test.cpp). What the plugin itself refuses:
  EXPECT_THROW(localizer->update(Imu{}), InputError);

  EXPECT_TRUE(localizer->update(scan).estimate.has_value());
  EXPECT_FALSE(localizer->update(odometry_at(Pose2(0, 0, 0), 2'000'000'000)).estimate.has_value());
  // A scan stamped before the latest odometry (but after the previous scan) is still fused.
  LaserScan late = scan;
  late.header.stamp_ns += 1;
  EXPECT_TRUE(localizer->update(late).estimate.has_value());
  PoseEstimate bad_pose;
  bad_pose.covariance(0, 0) = -1.0;
  EXPECT_THROW(localizer->set_pose(bad_pose), InputError);

  scan.header.stamp_ns += 40'000'000;
  const UpdateResult after = localizer->update(scan);
  ASSERT_TRUE(after.estimate.has_value());
  EXPECT_LT((after.estimate->pose.translation().head<2>() - Eigen::Vector2d(6.0, 1.5)).norm(), 0.05);
}

TEST_F(FeatureEkfPlugin, TheExampleConfigConfiguresWithTheCorridorMap) {
  const Params config = Params::load_file(test::source_dir() + "/config/plugins/feature_ekf.yaml");
  EXPECT_EQ(config.text("plugin", ""), "feature_ekf");
  context_.maps = MapResolver({std::filesystem::path(test::source_dir()) / "config" / "maps"});
  LocalizerPtr localizer =
      create_configured(catalog_, "feature_ekf", context_, Params(config.node()["params"], "feature_ekf"));
  const UpdateResult outputs = localizer->initial_outputs();
  ASSERT_TRUE(outputs.landmark_map.has_value());
  EXPECT_GT(outputs.landmark_map->size(), 50u);
}
