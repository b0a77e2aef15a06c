#include "localizer.hpp"

#include <cmath>
#include <system_error>

#include "params.hpp"

namespace locd::icp_explorer {

void IcpExplorerLocalizer::configure(const PluginContext& context, const Params& params) {
  const IcpExplorerConfig config = parse_config(params, context.limits);
  context_ = context;
  map_output_ = config.map_output;
  explorer_ = std::make_unique<IcpExplorer>(config);
}

void IcpExplorerLocalizer::set_pose(const PoseEstimate& pose) {
  if (!pose.pose.matrix().allFinite()) throw InputError("initial pose: non-finite values");
  if (explorer_) explorer_->set_pose(pose.pose, pose.covariance);
}

UpdateResult IcpExplorerLocalizer::update(const Measurement& measurement) {
  if (!explorer_) throw InputError("icp_explorer: update before configure");
  UpdateResult result;
  if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    explorer_->add_odometry(*odometry);
    return result;
  }
  const auto* cloud = std::get_if<PointCloud>(&measurement);
  if (!cloud) throw InputError(std::string("icp_explorer: consumes odometry and cloud, not ") + kind_name(kind_of(measurement)));
  const ScanOutcome outcome = explorer_->add_scan(*cloud);
  if (outcome.intensity_missing) {
    if (clouds_without_intensity_++ == 0)
      context_.log(LogLevel::kWarning, "icp_explorer: cloud without intensity; rejection rule (a) is off for such scans");
  }
  non_finite_points_ += outcome.non_finite_points;

  PoseEstimate estimate;
  estimate.header.stamp_ns = cloud->header.stamp_ns;
  estimate.header.frame_id = "map";
  estimate.pose = outcome.T_map_base;
  estimate.covariance = outcome.covariance;
  result.estimate = estimate;
  result.localization = outcome.localization;

  auto& v = result.diagnostics.values;
  const RegistrationResult& r = outcome.registration;
  v.emplace_back("scans", static_cast<double>(explorer_->scans()));
  v.emplace_back("registered", outcome.registered ? 1.0 : 0.0);
  v.emplace_back("converged", r.converged ? 1.0 : 0.0);
  v.emplace_back("iterations", r.iterations);
  v.emplace_back("correspondences", static_cast<double>(r.correspondences));
  v.emplace_back("rejected_intensity", static_cast<double>(r.counts[static_cast<size_t>(Rejection::kIntensity)]));
  v.emplace_back("rejected_overlap", static_cast<double>(r.counts[static_cast<size_t>(Rejection::kOverlap)]));
  v.emplace_back("rejected_error_length", static_cast<double>(r.counts[static_cast<size_t>(Rejection::kErrorLength)]));
  v.emplace_back("rejected_error_direction",
                 static_cast<double>(r.counts[static_cast<size_t>(Rejection::kErrorDirection)]));
  v.emplace_back("beyond_correspondence_distance", static_cast<double>(r.beyond_distance));
  v.emplace_back("rms_error_m", r.rms_error);
  v.emplace_back("coarse_iterations", r.coarse_iterations);
  v.emplace_back("inlier_share", r.inlier_share);
  v.emplace_back("inlier_rms_m", r.inlier_rms);
  v.emplace_back("kernel_scale_m", r.kernel_scale);
  v.emplace_back("degenerate_directions", r.degenerate_directions);
  v.emplace_back("smallest_constraint_share", r.constraint_shares(0));
  v.emplace_back("added_to_model", outcome.added_to_model ? 1.0 : 0.0);
  v.emplace_back("intensity_scale", explorer_->intensity_scale());
  v.emplace_back("source_points", static_cast<double>(outcome.source_points));
  v.emplace_back("non_finite_points", static_cast<double>(outcome.non_finite_points));
  v.emplace_back("non_finite_points_total", static_cast<double>(non_finite_points_));
  v.emplace_back("clouds_without_intensity", static_cast<double>(clouds_without_intensity_));
  v.emplace_back("preprocess_ms", outcome.preprocess_ms);
  v.emplace_back("registration_ms", outcome.registration_ms);
  v.emplace_back("model_update_ms", outcome.model_update_ms);
  v.emplace_back("carved_voxels", static_cast<double>(outcome.carved_voxels));
  v.emplace_back("planning_ms", outcome.planning_ms);
  v.emplace_back("model_points", static_cast<double>(explorer_->model().size()));

  if (outcome.exploration) {
    const ExplorationDecision& d = *outcome.exploration;
    ExplorationGoal goal;
    goal.header = estimate.header;
    goal.pose = Eigen::Isometry3d::Identity();
    goal.pose.translation() = Eigen::Vector3d(d.goal.x(), d.goal.y(), 0.0);
    goal.pose.linear() = Eigen::AngleAxisd(d.heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    goal.score = d.score;
    goal.done = d.done;
    result.exploration_goal = goal;
    v.emplace_back("exploration_score", d.score);
    v.emplace_back("exploration_done", d.done ? 1.0 : 0.0);
    v.emplace_back("exploration_candidates", static_cast<double>(d.candidates));
  }

  if (map_output_.publish_every_scans > 0 && explorer_->scans() % map_output_.publish_every_scans == 0) {
    const ScanPoints map = explorer_->model().downsampled(map_output_.publish_voxel_size);
    PointCloud cloud_map;
    cloud_map.header.stamp_ns = cloud->header.stamp_ns;
    cloud_map.header.frame_id = "map";
    cloud_map.points.reserve(map.size());
    for (const auto& p : map.points) cloud_map.points.push_back(p.cast<float>());
    bool any_intensity = false;
    for (float i : map.intensity) any_intensity |= std::isfinite(i);
    if (any_intensity)
      for (float i : map.intensity) cloud_map.intensity.push_back(std::isfinite(i) ? i : 0.0f);
    result.map_cloud = std::move(cloud_map);
  }
  return result;
}

std::string IcpExplorerLocalizer::save_map() {
  if (!explorer_) throw InputError("icp_explorer: save_map before configure");
  if (context_.output_directory.empty())
    throw InputError("icp_explorer: map saving is disabled on this server; set output_directory in the server config");
  if (explorer_->model().empty()) throw InputError("icp_explorer: the map is empty (no scan yet)");
  const auto file =
      generated_map_file(context_.output_directory, context_.robot_id, explorer_->scans(), map_output_.save_format);
  const ScanPoints map = explorer_->model().downsampled(explorer_->model().voxel_size());
  try {
    if (map_output_.save_format == MapFileFormat::kPcd)
      write_pcd(file, map);
    else
      write_ply(file, map);
  } catch (const std::exception& e) {
    throw InputError(std::string("icp_explorer: saving the map failed: ") + e.what());
  }
  context_.log(LogLevel::kInfo, "icp_explorer: map saved to " + file.string());
  return file.string();
}

}  // namespace locd::icp_explorer
