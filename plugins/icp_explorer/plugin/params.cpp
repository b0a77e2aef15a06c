#include "params.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace locd::icp_explorer {

namespace {
constexpr double kDegree = M_PI / 180.0;

// icp: the registration's iterations, kernels, coarse stage, degeneracy and trust.
void parse_icp(const Params& icp, IcpSettings& s) {
  icp.expect_only({"metric", "max_iterations", "max_correspondence_distance", "kernel_scale", "initial_kernel_scale",
                   "coarse_stride", "convergence_translation", "convergence_rotation", "coarse_stage", "degeneracy",
                   "trust"});
  s.metric = icp.text("metric", "point_to_plane", {"point_to_plane", "point_to_point"}) == "point_to_plane"
                 ? IcpMetric::kPointToPlane
                 : IcpMetric::kPointToPoint;
  s.max_iterations = static_cast<int>(icp.integer("max_iterations", s.max_iterations, 1, 500));
  s.max_correspondence_distance =
      icp.number("max_correspondence_distance", s.max_correspondence_distance, Range{0.0, 50.0, true, false});
  s.kernel_scale = icp.number("kernel_scale", s.kernel_scale, Range{0.0, 10.0, true, false});
  s.initial_kernel_scale = icp.number("initial_kernel_scale", s.initial_kernel_scale, Range{0.0, 10.0, true, false});
  s.coarse_stride = static_cast<int>(icp.integer("coarse_stride", s.coarse_stride, 1, 64));
  s.convergence_translation = icp.number("convergence_translation", s.convergence_translation, Range::open(0.0, 1.0));
  s.convergence_rotation = icp.number("convergence_rotation", s.convergence_rotation, Range::open(0.0, 1.0));
  const Params coarse = icp.child("coarse_stage");
  coarse.expect_only({"enabled", "voxel_size", "initial_kernel_scale", "kernel_scale"});
  s.coarse.enabled = coarse.flag("enabled", s.coarse.enabled);
  s.coarse.voxel_size = coarse.number("voxel_size", s.coarse.voxel_size, Range::closed(0.05, 10.0));
  s.coarse.initial_kernel_scale =
      coarse.number("initial_kernel_scale", s.coarse.initial_kernel_scale, Range{0.0, 50.0, true, false});
  s.coarse.kernel_scale = coarse.number("kernel_scale", s.coarse.kernel_scale, Range{0.0, 50.0, true, false});
  const Params degeneracy = icp.child("degeneracy");
  degeneracy.expect_only({"hold_to_prior", "min_constraint_share", "confident_constraint_share"});
  s.degeneracy.hold_to_prior = degeneracy.flag("hold_to_prior", s.degeneracy.hold_to_prior);
  s.degeneracy.min_constraint_share =
      degeneracy.number("min_constraint_share", s.degeneracy.min_constraint_share, Range{0.0, 1.0, false, true});
  s.degeneracy.confident_constraint_share = degeneracy.number(
      "confident_constraint_share", s.degeneracy.confident_constraint_share, Range{0.0, 1.0, false, true});
  if (s.degeneracy.confident_constraint_share < s.degeneracy.min_constraint_share)
    degeneracy.fail("confident_constraint_share", "must be at least min_constraint_share (" +
                                                      std::to_string(s.degeneracy.min_constraint_share) + ")");
  const Params trust = icp.child("trust");
  trust.expect_only({"min_inlier_share", "inlier_distance", "overlap_distance", "max_rms_error", "max_degenerate_directions"});
  s.trust.min_inlier_share = trust.number("min_inlier_share", s.trust.min_inlier_share, Range::closed(0.0, 1.0));
  s.trust.inlier_distance = trust.number("inlier_distance", s.trust.inlier_distance, Range{0.0, 10.0, true, false});
  s.trust.overlap_distance =
      trust.number("overlap_distance", s.trust.overlap_distance, Range{0.0, 50.0, true, false});
  s.trust.max_rms_error = trust.number("max_rms_error", s.trust.max_rms_error, Range{0.0, 10.0, true, false});
  s.trust.max_degenerate_directions =
      static_cast<int>(trust.integer("max_degenerate_directions", s.trust.max_degenerate_directions, 0, 6));
}

// rejection: the correspondence rejection rules.
void parse_rejection(const Params& rules, RejectionRules& r) {
  rules.expect_only({"intensity", "overlap", "error_length", "error_direction", "intensity_threshold", "max_range"});
  r.intensity = rules.flag("intensity", r.intensity);
  r.overlap = rules.flag("overlap", r.overlap);
  r.error_length = rules.flag("error_length", r.error_length);
  r.error_direction = rules.flag("error_direction", r.error_direction);
  r.intensity_threshold =
      rules.number("intensity_threshold", r.intensity_threshold, Range{0.0, 1.0, true, false});
  r.max_range = rules.number("max_range", r.max_range, Range{0.0, 500.0, true, false});
}

// odometry_bound: how far a registration may move from the odometry's prior.
void parse_odometry_bound(const Params& bound, OdometryErrorBound& b) {
  bound.expect_only({"forward", "lateral", "vertical", "yaw_deg", "tilt_deg", "margin"});
  b.forward = bound.number("forward", b.forward, Range::closed(0.0, 20.0));
  b.lateral = bound.number("lateral", b.lateral, Range::closed(0.0, 20.0));
  b.vertical = bound.number("vertical", b.vertical, Range::closed(0.0, 5.0));
  b.yaw = bound.number("yaw_deg", b.yaw / kDegree, Range::closed(0.0, 180.0)) * kDegree;
  b.tilt = bound.number("tilt_deg", b.tilt / kDegree, Range::closed(0.0, 45.0)) * kDegree;
  b.margin = bound.number("margin", b.margin, Range::closed(0.0, 5.0));
}

// exploration: the layered map and the next-best-view planner (after `rejection`: the planner
// sees as far as the scans are used).
void parse_exploration(const Params& e, const Limits& limits, IcpExplorerConfig& c) {
  e.expect_only({"enabled", "origin", "size", "cell_size", "layer_height", "z_min", "z_max", "occupied_probability",
                 "points_for_detection", "fill", "azimuth_step_deg", "elevation_step_deg", "elevation_min_deg",
                 "elevation_max_deg", "sensor_height", "beta", "possibly_movable_weight", "robot_radius",
                 "robot_height", "rays", "candidate_stride", "reliable_distance", "reliable_falloff",
                 "overlap_distance", "direction_penalty", "memory_radius", "done_threshold"});
  c.exploration = e.flag("enabled", c.exploration);
  LayeredMapSettings& m = c.layered_map;
  const auto origin = e.numbers("origin", {m.origin.x(), m.origin.y()}, 2, Range::closed(-1e5, 1e5));
  const auto size = e.numbers("size", {m.size.x(), m.size.y()}, 2, Range{0.0, 1e4, true, false});
  m.origin = {origin[0], origin[1]};
  m.size = {size[0], size[1]};
  m.cell_size = e.number("cell_size", m.cell_size, Range::closed(0.05, 5.0));
  m.layer_height = e.number("layer_height", m.layer_height, Range::closed(0.05, 5.0));
  m.z_min = e.number("z_min", m.z_min, Range::closed(-10.0, 50.0));
  m.z_max = e.number("z_max", m.z_max, Range::closed(-10.0, 50.0));
  if (m.z_max < m.z_min + m.layer_height)
    e.fail("z_max", "must leave room for one layer above z_min (" + std::to_string(m.z_min) + " + layer_height)");
  const double cells = std::ceil(m.size.x() / m.cell_size) * std::ceil(m.size.y() / m.cell_size) *
                       std::floor((m.z_max - m.z_min) / m.layer_height);
  if (c.exploration && cells > static_cast<double>(limits.max_map_cells))
    e.fail("size", "gives " + std::to_string(static_cast<long long>(cells)) + " cubes; the server allows " +
                       std::to_string(limits.max_map_cells) + " map cells");
  m.occupied_probability = e.number("occupied_probability", m.occupied_probability, Range::open(0.0, 1.0));
  m.points_for_detection = e.number("points_for_detection", m.points_for_detection, Range::closed(1.0, 1000.0));
  m.fill = e.number("fill", m.fill, Range{0.0, 1.0, true, false});
  m.azimuth_step = e.number("azimuth_step_deg", m.azimuth_step / kDegree, Range{0.0, 45.0, true, false}) * kDegree;
  m.elevation_step = e.number("elevation_step_deg", m.elevation_step / kDegree, Range{0.0, 45.0, true, false}) * kDegree;
  ExplorationSettings& x = c.planner;
  x.elevation_min = e.number("elevation_min_deg", x.elevation_min / kDegree, Range::closed(-90.0, 90.0)) * kDegree;
  x.elevation_max = e.number("elevation_max_deg", x.elevation_max / kDegree, Range::closed(-90.0, 90.0)) * kDegree;
  if (x.elevation_max <= x.elevation_min) e.fail("elevation_max_deg", "must exceed elevation_min_deg");
  x.sensor_height = e.number("sensor_height", x.sensor_height, Range::closed(0.0, 10.0));
  x.max_range = c.rejection.max_range;
  x.beta = e.number("beta", x.beta, Range::closed(0.0, 100.0));
  x.possibly_movable_weight = e.number("possibly_movable_weight", x.possibly_movable_weight, Range::closed(0.0, 1.0));
  x.robot_radius = e.number("robot_radius", x.robot_radius, Range::closed(0.0, 5.0));
  x.robot_height = e.number("robot_height", x.robot_height, Range{0.0, 10.0, true, false});
  x.rays = static_cast<int>(e.integer("rays", x.rays, 8, 3600));
  x.candidate_stride = static_cast<int>(e.integer("candidate_stride", x.candidate_stride, 1, 100));
  x.reliable_distance = e.number("reliable_distance", x.reliable_distance, Range::closed(0.0, 1000.0));
  x.reliable_falloff = e.number("reliable_falloff", x.reliable_falloff, Range{0.0, 1000.0, true, false});
  x.overlap_distance = e.number("overlap_distance", x.overlap_distance, Range{0.0, 100.0, true, false});
  x.direction_penalty = e.number("direction_penalty", x.direction_penalty, Range{0.0, 1.0, false, true});
  x.memory_radius = e.number("memory_radius", x.memory_radius, Range::closed(0.0, 1000.0));
  x.done_threshold = e.number("done_threshold", x.done_threshold, Range::non_negative());
}

// map_output: how the map is published and saved.
void parse_map_output(const Params& out, MapOutputSettings& o) {
  out.expect_only({"publish_every_scans", "publish_voxel_size", "save_format"});
  o.publish_every_scans = static_cast<int>(out.integer("publish_every_scans", o.publish_every_scans, 0, 100000));
  o.publish_voxel_size = out.number("publish_voxel_size", o.publish_voxel_size, Range::closed(0.01, 10.0));
  o.save_format = out.text("save_format", "pcd", {"pcd", "ply"}) == "pcd" ? MapFileFormat::kPcd : MapFileFormat::kPly;
}

}  // namespace

IcpExplorerConfig parse_config(const Params& p, const Limits& limits) {
  p.expect_only({"max_points", "intensity_scale", "scan_voxel_size", "map_voxel_size", "normal_neighbours", "carve_free_space",
                 "carve_min_rays", "icp", "rejection", "odometry_bound", "exploration", "map_output"});
  IcpExplorerConfig c;
  c.max_points = static_cast<size_t>(p.integer("max_points", static_cast<long>(std::min(c.max_points, limits.max_cloud_points)),
                                               1, static_cast<long>(limits.max_cloud_points)));
  // intensity_scale: "auto" (estimated from the first cloud) or the intensity of full reflectivity.
  const YAML::Node scale = p.node()["intensity_scale"];
  if (scale && scale.IsScalar() && scale.Scalar() == "auto") {
    c.intensity_scale = 0.0;
  } else {
    c.intensity_scale = p.number("intensity_scale", c.intensity_scale, Range::non_negative());
    if (p.has("intensity_scale") && c.intensity_scale == 0.0)
      p.fail("intensity_scale", "must be \"auto\" or a positive number (the intensity of full reflectivity, e.g. 1 or 255)");
  }
  c.scan_voxel_size = p.number("scan_voxel_size", c.scan_voxel_size, Range::closed(0.01, 5.0));
  c.map_voxel_size = p.number("map_voxel_size", c.map_voxel_size, Range::closed(0.01, 2.0));
  c.normal_neighbours = static_cast<int>(p.integer("normal_neighbours", c.normal_neighbours, 3, 64));
  c.carve_free_space = p.flag("carve_free_space", c.carve_free_space);
  c.carve_min_rays = static_cast<int>(p.integer("carve_min_rays", c.carve_min_rays, 1, 1000));

  parse_icp(p.child("icp"), c.icp);
  parse_rejection(p.child("rejection"), c.rejection);
  parse_odometry_bound(p.child("odometry_bound"), c.odometry_bound);
  parse_exploration(p.child("exploration"), limits, c);
  parse_map_output(p.child("map_output"), c.map_output);
  return c;
}

}  // namespace locd::icp_explorer
