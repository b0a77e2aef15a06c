// feature_ekf's localizers: thin I/O around the core filters. Two models, two Localizers:
//   LaserFeatureLocalizer  odometry + 2D scans against a wall feature map (FeatureEkfFilter)
//   LandmarkLocalizer      imu + landmark detections against a database (LandmarkEkfFilter)
// The plugin registers FeatureEkfLocalizer under the name `feature_ekf`: its configure reads the
// parameters (the `model` key picks the model, laser_features by default) and hands every later
// call to the localizer of that model, so both configs in config/plugins name `plugin: feature_ekf`.
#pragma once

#include <memory>
#include <string>

#include "locd/feature_ekf/relocalizing_feature_ekf.hpp"
#include "locd/feature_ekf/landmark_ekf_filter.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::feature_ekf {

class LaserFeatureLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void configure(const PluginContext& context, const Config& config);
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

 private:
  UpdateResult on_scan(const LaserScan& scan);
  std::unique_ptr<RelocalizingFeatureEkf> filter_;
};

class LandmarkLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void configure(const PluginContext& context, const Config& config);
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

 private:
  UpdateResult on_detections(const LandmarkDetections& detections);
  std::unique_ptr<LandmarkEkfFilter> filter_;
  LocalizationMonitor monitor_;  // over detection frames: association share and NIS (no scan agreement)
  std::string frame_id_ = "map";
};

// What the plugin registers: picks LaserFeatureLocalizer or LandmarkLocalizer by `model`.
class FeatureEkfLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

 private:
  Localizer& model() const;
  std::unique_ptr<Localizer> model_;
};

}  // namespace locd::feature_ekf
