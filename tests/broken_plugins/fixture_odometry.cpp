// A good fixture plugin for the loader and server tests (never installed): the pose is the
// odometry pose composed onto the pose given by set_pose, T_map_base = T_map_odom * T_odom_base,
// with T_map_odom fixed when the pose is set. Scans are checked (an all-NaN or empty scan is an
// InputError) and counted, but do not correct the pose.
#include <cmath>

#include "locd/sdk/plugin.hpp"

namespace {

class OdometryFixture : public locd::Localizer {
 public:
  void configure(const locd::PluginContext&, const locd::Params& params) override {
    params.expect_only({"position_stddev"});
    position_stddev_ = params.number("position_stddev", 0.1, locd::Range::positive());
  }

  void set_pose(const locd::PoseEstimate& pose) override {
    map_from_base_ = pose.pose;
    pose_set_ = true;
  }

  locd::UpdateResult update(const locd::Measurement& measurement) override {
    locd::UpdateResult result;
    if (const auto* scan = std::get_if<locd::LaserScan>(&measurement)) {
      size_t returns = 0;
      for (size_t i = 0; i < scan->ranges.size(); ++i) returns += scan->valid_return(i);
      if (returns == 0) throw locd::InputError("scan has no valid return");
      ++scans_;
      result.diagnostics.values.push_back({"scans", static_cast<double>(scans_)});
      return result;
    }
    const auto* odometry = std::get_if<locd::Odometry>(&measurement);
    if (!odometry) throw locd::InputError("fixture_odometry consumes odometry and scans only");
    if (!odom_known_ || pose_set_) {
      // Anchor: map_from_odom maps the current odometry pose onto the current map pose.
      map_from_odom_ = map_from_base_ * odometry->pose.inverse();
      odom_known_ = true;
      pose_set_ = false;
    }
    map_from_base_ = map_from_odom_ * odometry->pose;
    locd::PoseEstimate estimate;
    estimate.header = {odometry->header.stamp_ns, "map"};
    estimate.pose = map_from_base_;
    estimate.covariance = locd::Matrix6d::Identity() * position_stddev_ * position_stddev_;
    result.estimate = estimate;
    return result;
  }

 private:
  double position_stddev_ = 0.1;
  Eigen::Isometry3d map_from_base_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d map_from_odom_ = Eigen::Isometry3d::Identity();
  bool pose_set_ = false;
  bool odom_known_ = false;
  size_t scans_ = 0;
};

}  // namespace

LOCD_REGISTER_PLUGIN(OdometryFixture, "fixture_odometry", "0.1.0",
                     "test fixture: odometry composed onto the set pose",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))
