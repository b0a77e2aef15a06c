// Runs feature_ekf's LandmarkEkfFilter (feature_ekf_core, which the user links) over a simulated
// road-sign drive and scores it: horizontal error once per second, associations against the
// simulator's truth. Shared by feature_ekf's tests and benchmarks.
#pragma once

#include <cmath>
#include <vector>

#include "locd/feature_ekf/landmark_ekf_filter.hpp"
#include "locd/sim_feature_ekf/road_sign_drive.hpp"

namespace locd::sim::road_signs {

using feature_ekf::AssociationStrategy;
using feature_ekf::Landmark;
using feature_ekf::LandmarkDatabase;
using feature_ekf::LandmarkEkfConfig;
using feature_ekf::LandmarkEkfFilter;
using feature_ekf::LandmarkModelKind;
using feature_ekf::LandmarkUpdateReport;

inline LandmarkDatabase database_of(const RoadSignWorld& world) {
  std::vector<Landmark> landmarks;
  for (const RoadSign& s : world.signs())
    landmarks.push_back({s.id, s.class_label, s.latitude_deg, s.longitude_deg});
  return LandmarkDatabase(std::move(landmarks), "simulated world");
}

inline LandmarkEkfConfig config_for(const RoadSignWorld& world, AssociationStrategy strategy,
                                    LandmarkModelKind model = LandmarkModelKind::kGeodetic) {
  LandmarkEkfConfig c;
  c.model = model;
  c.association.strategy = strategy;
  c.centre_deg = Eigen::Vector2d(world.config().centre_latitude_deg, world.config().centre_longitude_deg);
  c.altitude = world.config().altitude;
  return c;
}

struct FilterRunResult {
  std::vector<double> times;         // s, once per second
  std::vector<double> errors;        // m, horizontal
  std::vector<double> velocity_errors;  // m/s
  size_t detections = 0, true_detections = 0, false_detections = 0;
  size_t applied = 0, wrong = 0, false_associated = 0;
  // Per second: wrong associations made during that second (for the probability over time).
  std::vector<size_t> wrong_per_second, detections_per_second;
  double final_error() const { return errors.empty() ? 0.0 : errors.back(); }
  double max_error() const {
    double m = 0.0;
    for (double e : errors) m = std::max(m, e);
    return m;
  }
};

inline FilterRunResult run_drive(const RoadSignWorld& world, const DriveConfig& drive_config,
                           LandmarkEkfConfig config, uint64_t route_seed, uint64_t noise_seed,
                           const Eigen::Vector2d& initial_offset, double until = 1e300) {
  RoadSignDrive drive(world, drive_config, route_seed, noise_seed);
  const DriveTruth start = drive.truth();
  config.initial_position = start.position + initial_offset;
  config.initial_velocity = start.velocity;
  LandmarkEkfFilter filter(config, database_of(world));
  FilterRunResult r;
  double next_sample = 0.0;
  size_t second_wrong = 0, second_detections = 0;
  while (auto e = drive.next(until)) {
    if (const auto* imu = std::get_if<Imu>(&e->measurement)) {
      filter.apply_imu(*imu);
      if (e->truth.time >= next_sample) {
        r.times.push_back(e->truth.time);
        r.errors.push_back((filter.position_enu() - e->truth.position).norm());
        r.velocity_errors.push_back((filter.velocity_enu() - e->truth.velocity).norm());
        r.wrong_per_second.push_back(second_wrong);
        r.detections_per_second.push_back(second_detections);
        second_wrong = second_detections = 0;
        next_sample += 1.0;
      }
    } else if (const auto* frame = std::get_if<LandmarkDetections>(&e->measurement)) {
      const LandmarkUpdateReport report = filter.update(*frame);
      for (size_t k = 0; k < report.detections.size(); ++k) {
        const int truth = e->true_signs[k];
        const int chosen = report.detections[k].landmark;
        ++r.detections;
        ++second_detections;
        truth >= 0 ? ++r.true_detections : ++r.false_detections;
        if (report.detections[k].applied) ++r.applied;
        if (chosen >= 0 && chosen != truth) {
          ++r.wrong;
          ++second_wrong;
          if (truth < 0) ++r.false_associated;
        }
      }
    }
  }
  return r;
}

}  // namespace locd::sim::road_signs
