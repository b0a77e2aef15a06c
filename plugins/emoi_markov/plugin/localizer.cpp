#include "localizer.hpp"

#include <cmath>
#include <string>

#include "params.hpp"

namespace locd::emoi {
namespace {

// configure logs the EMOI precompute's progress this many times (every 10 %).
constexpr int kProgressSteps = 10;
// Characters of the cache key named in the log.
constexpr size_t kLoggedKeyLength = 12;

}  // namespace

void EmoiMarkovLocalizer::configure(const PluginContext& context, const Params& params) {
  const EmoiMarkovConfig config = parse_config(params);
  ElevationMap dsm = load_dsm(context.maps.resolve(config.map), context.limits.max_map_cells);
  configure(context, config, std::move(dsm));
}

void EmoiMarkovLocalizer::configure(const PluginContext& context, const EmoiMarkovConfig& config, ElevationMap dsm) {
  int last_step = -1;
  const ProgressCallback progress = [&](double fraction, const std::string& stage) {
    const int step = static_cast<int>(fraction * kProgressSteps);
    if (step == last_step) return;
    last_step = step;
    context.log(LogLevel::kInfo,
                "emoi_markov: EMOI layers " + std::to_string(step * 100 / kProgressSteps) + "% (" + stage + ")");
  };
  filter_ = std::make_unique<EmoiMarkovFilter>(config, std::move(dsm), context.limits.max_map_cells, progress);
  if (filter_->full_disk_layers()) {
    context.log(LogLevel::kInfo, std::string("emoi_markov: EMOI layers ") +
                                     (filter_->layers_from_cache() ? "read from the cache" : "computed") + " (key " +
                                     filter_->layers_key().substr(0, kLoggedKeyLength) + ")");
  }
}

const EmoiMarkovFilter& EmoiMarkovLocalizer::filter() const {
  if (!filter_) throw InputError("emoi_markov: not configured");
  return *filter_;
}

void EmoiMarkovLocalizer::set_pose(const PoseEstimate& pose) {
  if (!filter_) throw InputError("set_pose before configure");
  filter_->set_pose(pose);
}

UpdateResult EmoiMarkovLocalizer::update(const Measurement& measurement) {
  if (!filter_) throw InputError("measurement before configure");
  if (const auto* odometry = std::get_if<Odometry>(&measurement)) {
    filter_->add_odometry(*odometry);
    UpdateResult result;
    result.estimate = filter_->estimate(odometry->header.stamp_ns);
    // Judged at sensor updates; until the first one the state of the start (lost, or the initial
    // pose's) goes with every pose.
    if (filter_->sensor_updates() == 0) result.localization = filter_->assessment().localization;
    return result;
  }
  if (const auto* imu = std::get_if<Imu>(&measurement)) {
    filter_->add_imu(*imu);
    return {};
  }
  if (const auto* scan = std::get_if<LaserScan>(&measurement)) {
    return sensor_update_result(scan->header.stamp_ns, filter_->add_scan(*scan));
  }
  if (const auto* cloud = std::get_if<PointCloud>(&measurement)) {
    return sensor_update_result(cloud->header.stamp_ns, filter_->add_cloud(*cloud));
  }
  throw InputError(std::string("emoi_markov does not consume '") + kind_name(kind_of(measurement)) +
                   "' measurements; it consumes odometry, imu, scan and cloud");
}

UpdateResult EmoiMarkovLocalizer::sensor_update_result(int64_t stamp_ns,
                                                       const std::optional<FilterUpdateReport>& report) const {
  UpdateResult result;
  if (!report) return result;
  result.estimate = filter_->estimate(stamp_ns);
  result.grid = filter_->belief_layer();
  const BeliefAssessment& assessment = filter_->assessment();
  result.localization = assessment.localization;
  const EmoiMarkovConfig& config = filter_->config();
  auto& values = result.diagnostics.values;
  for (size_t i = 0; i < config.radii_m.size(); ++i) {
    const std::string r = std::to_string(static_cast<int>(std::lround(config.radii_m[i])));
    values.emplace_back("emoi_r" + r, report->robot_emoi[i].emoi);
    values.emplace_back("coverage_r" + r, report->robot_emoi[i].coverage);
    values.emplace_back("weight_r" + r, report->weights[i]);
  }
  values.emplace_back("distortion_cells", static_cast<double>(report->distortion.cells));
  values.emplace_back("distortion_scale", report->distortion.scale);
  values.emplace_back("distortion_direction_rad", report->distortion.direction_rad);
  values.emplace_back("sensor_update_applied", report->sensor.applied ? 1.0 : 0.0);
  values.emplace_back("evidence", report->sensor.evidence);
  values.emplace_back("mass_lost", report->motion.mass_lost);
  values.emplace_back("belief_resets", static_cast<double>(filter_->belief_resets()));
  values.emplace_back("max_probability", filter_->summary().max_probability);
  values.emplace_back("effective_cells", filter_->summary().effective_cells);
  values.emplace_back("modes", static_cast<double>(assessment.modes.size()));
  values.emplace_back("belief_area_m2", assessment.area_m2);
  values.emplace_back("peak_mass", assessment.peak_mass);
  if (std::isfinite(assessment.fit_rms_m)) values.emplace_back("fit_rms_m", assessment.fit_rms_m);
  values.emplace_back("sensor_updates", static_cast<double>(filter_->sensor_updates()));
  values.emplace_back("rejected_points", static_cast<double>(filter_->rejected_points()));
  return result;
}

UpdateResult EmoiMarkovLocalizer::initial_outputs() const {
  UpdateResult result;
  if (!filter_) return result;
  result.grid = filter_->belief_layer();
  return result;
}

}  // namespace locd::emoi
