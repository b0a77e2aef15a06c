// The built plugin with a landmark model, loaded like the server loads it: model selection,
// database through the map directories, a simulated drive in, poses with velocity and association
// records out; config and input errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "plugin_fixture.hpp"
#include "locd/sim_feature_ekf/road_sign_drive.hpp"
#include "test_env.hpp"

using namespace locd;
namespace rs = locd::sim::road_signs;

namespace {

class FeatureEkfLandmarkPlugin : public test::FeatureEkfPluginFixture {
 protected:
  FeatureEkfLandmarkPlugin() : FeatureEkfPluginFixture("car", "signs.csv", world().database_csv()) {}
  static const rs::RoadSignWorld& world() {
    static const rs::RoadSignWorld w{rs::WorldConfig{}};
    return w;
  }
  std::string base(const std::string& model = "geodetic_landmarks") const {
    return "  model: " + model + "\n  landmarks: signs.csv\n  centre: [" + std::to_string(world_.config().centre_latitude_deg) +
           ", " + std::to_string(world_.config().centre_longitude_deg) + "]\n  altitude: 50.0\n";
  }

  const rs::RoadSignWorld& world_ = world();
};

std::string input_error(Localizer& l, const Measurement& m) {
  try {
    l.update(m);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

}  // namespace

TEST_F(FeatureEkfLandmarkPlugin, DescriptorConsumesAllFourKinds) {
  const auto library = catalog_.find("feature_ekf");
  ASSERT_TRUE(library);
  const uint32_t kinds = library->descriptor().consumes;
  for (MeasurementKind k : {MeasurementKind::kOdometry, MeasurementKind::kLaserScan, MeasurementKind::kImu,
                            MeasurementKind::kLandmarkDetections}) {
    EXPECT_TRUE(kinds & static_cast<uint32_t>(k)) << kind_name(k);
  }
}

TEST_F(FeatureEkfLandmarkPlugin, TracksADriveAndReportsAssociations) {
  for (const char* model : {"geodetic_landmarks", "enu_landmarks"}) {
    LocalizerPtr plugin = configured(base(model) + "  association: pda\n");
    const UpdateResult initial = plugin->initial_outputs();
    ASSERT_TRUE(initial.landmark_map.has_value());
    ASSERT_EQ(initial.landmark_map->size(), world_.signs().size());
    EXPECT_EQ((*initial.landmark_map)[0].kind, world_.signs()[0].class_label);
    EXPECT_LT(((*initial.landmark_map)[5].a.head<2>() - world_.signs()[5].position).norm(), 0.01);

    rs::DriveConfig drive_config;
    drive_config.duration = 90.0;
    rs::RoadSignDrive drive(world_, drive_config, 5, 3);
    PoseEstimate start;
    start.pose.translation() << drive.truth().position.x() + 2.0, drive.truth().position.y() - 1.0, 0.0;
    start.linear_velocity << drive.truth().velocity, 0.0;
    start.covariance = Matrix6d::Identity() * 9.0;
    plugin->set_pose(start);
    size_t estimates = 0, records = 0, associated = 0, tracking = 0;
    double last_error = 1e9;
    while (auto e = drive.next()) {
      const UpdateResult r = plugin->update(e->measurement);
      if (std::holds_alternative<Imu>(e->measurement)) {
        EXPECT_FALSE(r.estimate.has_value());
        continue;
      }
      ASSERT_TRUE(r.estimate.has_value());
      ASSERT_TRUE(r.localization.has_value());  // every detection frame is judged (association, NIS)
      tracking += r.localization->state == LocalizationState::kTracking;
      ++estimates;
      last_error = (r.estimate->pose.translation().head<2>() - e->truth.position).norm();
      EXPECT_LT((r.estimate->linear_velocity.head<2>() - e->truth.velocity).norm(), 2.0);
      EXPECT_GT(r.estimate->covariance(0, 0), 0.0);
      records += r.diagnostics.associations.size();
      for (const AssociationRecord& a : r.diagnostics.associations) associated += a.feature_id.empty() ? 0 : 1;
      bool has_gate = false, has_latitude = false;
      for (const auto& [name, value] : r.diagnostics.values) {
        has_gate = has_gate || (name == "gate_threshold" && std::fabs(value - 11.9) < 1e-6);
        has_latitude = has_latitude || (name == "latitude_deg" && std::fabs(value - 36.1) < 0.05);
      }
      EXPECT_TRUE(has_gate && has_latitude);
    }
    EXPECT_GT(estimates, 80u);
    EXPECT_GT(records, 10u);
    EXPECT_GT(associated, 10u);
    EXPECT_LT(last_error, 8.0) << model;
    EXPECT_GT(tracking, estimates * 9 / 10) << model;
  }
}

TEST_F(FeatureEkfLandmarkPlugin, BadInputIsRejectedAndTheSessionGoesOn) {
  LocalizerPtr plugin = configured(base());
  LandmarkDetections frame;
  frame.header.stamp_ns = 10;
  frame.detections.push_back({"crosswalk", {20.0, 2.0, 0.0}, Eigen::Matrix3d::Identity()});
  EXPECT_NE(input_error(*plugin, frame).find("before any imu"), std::string::npos);
  Imu imu;
  imu.header.stamp_ns = 5;
  plugin->update(imu);
  // NaN attitudes, oversized frames and stamps going backwards never reach the plugin: the bridge
  // and the session refuse them (tests/sdk/validate_test.cpp, tests/server/session_test.cpp).
  LandmarkDetections unknown = frame;
  unknown.detections[0].class_label = "stop_sign";
  EXPECT_NE(input_error(*plugin, unknown).find("class 'stop_sign' is not in the landmark database"), std::string::npos);
  EXPECT_NE(input_error(*plugin, LaserScan{}).find("'scan' is not consumed by model geodetic_landmarks"), std::string::npos);
  EXPECT_TRUE(plugin->update(frame).estimate.has_value());
}

TEST_F(FeatureEkfLandmarkPlugin, ConfigErrorsNameTheKey) {
  EXPECT_NE(config_error(base() + "  association: greedy\n").find("feature_ekf.association"), std::string::npos);
  EXPECT_NE(config_error(base() + "  association: greedy\n").find("pda"), std::string::npos);
  EXPECT_NE(config_error("  model: sonar\n").find("feature_ekf.model"), std::string::npos);
  EXPECT_NE(config_error(base() + "  gate_threshold: -1\n").find("feature_ekf.gate_threshold"), std::string::npos);
  EXPECT_NE(config_error(base() + "  false_detection_probability: 1.0\n").find("feature_ekf.false_detection_probability"),
            std::string::npos);
  EXPECT_NE(config_error(base() + "  map: corridor.yaml\n").find("map"), std::string::npos);  // laser key, landmark model
  EXPECT_NE(config_error("  model: enu_landmarks\n  landmarks: signs.csv\n  centre: [95, 10]\n").find("feature_ekf.centre"), std::string::npos);
  EXPECT_NE(config_error("  model: enu_landmarks\n").find("feature_ekf.landmarks"), std::string::npos);
  EXPECT_NE(config_error("  model: enu_landmarks\n  landmarks: ../etc/passwd\n").find(".."), std::string::npos);
  std::ofstream(map_dir_ / "dup.csv") << "id,class,lat,lon\na,x,36.1,129.3\na,y,36.2,129.3\n";
  EXPECT_NE(config_error("  model: enu_landmarks\n  landmarks: dup.csv\n").find("duplicate id 'a'"), std::string::npos);
  std::ofstream(map_dir_ / "far.yaml") << "landmarks:\n  - {id: a, class: x, lat: 36.1, lon: 190}\n";
  EXPECT_NE(config_error("  model: enu_landmarks\n  landmarks: far.yaml\n").find("lon 190"), std::string::npos);
}

TEST_F(FeatureEkfLandmarkPlugin, LaserModelRejectsLandmarkKinds) {
  std::ofstream(map_dir_ / "room.yaml") << "walls:\n  - [[0, 0], [10, 0], [10, 8], [0, 8]]\nclosed: [true]\n";
  LocalizerPtr plugin = configured("  map: room.yaml\n");
  EXPECT_NE(input_error(*plugin, Imu{}).find("'imu' is not consumed by model laser_features"), std::string::npos);
}
