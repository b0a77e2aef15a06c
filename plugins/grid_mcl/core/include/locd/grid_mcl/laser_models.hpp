// The laser models of AMCL (Probabilistic Robotics ch. 6; Nav2 amcl's sensors/laser), on the
// shared map:
//
//   likelihood_field       Table 6.3's field: pz = z_hit exp(-d^2 / (2 sigma_hit^2)) + z_rand / z_max,
//                          d the distance from the beam's end to the nearest obstacle (saturating at
//                          laser_likelihood_max_dist, or beyond the map); a beam ending in an
//                          unknown cell or beyond the map scores u pz(0) + (1 - u) pz(d), u =
//                          unknown_occupancy (locd; 0 as AMCL). Weight factor as AMCL:
//                          1 + sum over beams of pz^3 (robust to unmodelled obstacles)
//   likelihood_field_prob  the same pz, as Table 6.3's product over beams (sharper, log domain)
//   beam                   Table 6.1's mixture along a ray cast on the grid: z_hit N(z*, sigma_hit^2)
//                          + z_short lambda e^(-lambda z) (z < z*) + z_max [z = z_max] + z_rand / z_max;
//                          weight factor 1 + sum pz^3 as AMCL
//
// Beams: at most max_beams, every (n - 1) / (max_beams - 1)-th of the scan as AMCL picks them.
// The likelihood field skips max-range readings (and no-returns); the beam model reads a no-return
// as z_max. The field's pz^3 (or log pz) comes from a table per distance unit of the shared
// DistanceField, built once per session and per z_max.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "locd/grid_mcl/config.hpp"
#include "locd/grid_mcl/shared_map.hpp"
#include "locd/sdk/particle_filter.hpp"
#include "locd/sdk/types.hpp"

namespace locd::grid_mcl {

// The beams the models use, in base_link.
struct PreparedScan {
  Eigen::Vector2d sensor_position = Eigen::Vector2d::Zero();  // in base_link
  std::vector<double> bearing;           // beam direction in base_link, rad
  std::vector<double> range;             // m; z_max for a no-return or a reading at or beyond it
  std::vector<Eigen::Vector2d> end;      // beam end in base_link (hits only)
  std::vector<uint8_t> hit;              // 1: a range below z_max (the field uses these)
  double z_max = 0.0;                    // laser_max_range or the scan's range_max
  size_t beams_in_scan = 0;
  size_t hits() const;
};

// Picks the beams (AMCL's step) and applies laser_min_range / laser_max_range. A scan plane
// tilted out of the horizontal is projected (the mount's yaw and an upside-down mount are honoured).
PreparedScan prepare_scan(const LaserScan& scan, const LaserModelConfig& config);

class LaserModel {
 public:
  LaserModel(std::shared_ptr<const SharedMap> map, const LaserModelConfig& config);

  // Weight factors of particles [begin, end): linear for likelihood_field and beam (multiply the
  // weight), log for likelihood_field_prob (add to the log weight); and each particle's mean pz
  // per beam at the configured sigma_hit (the recovery's measure, the same whatever the model and
  // while searching). Thread-safe for disjoint ranges once prepare(scan) has run.
  bool log_domain() const { return type_ == LaserModelType::kLikelihoodFieldProb; }
  void prepare(const PreparedScan& scan);
  void factors(const std::vector<PoseParticle>& particles, size_t begin, size_t end, const PreparedScan& scan,
               double* factor, double* mean_pz) const;
  // One pose, the direct formula (exp per beam, no table): the reference the fast path is tested
  // against. Same domain as factors().
  double factor_direct(const Pose2& pose, const PreparedScan& scan, double* mean_pz = nullptr) const;
  // Share of the scan's hits whose end lies within `distance` of an obstacle at this pose. With
  // known_only, a hit that ends away from any obstacle in a cell the map does not know (unknown,
  // or beyond the map), reached without passing an occupied cell, is not counted: it neither
  // agrees nor disagrees with the map (the part of a building the map lacks). One that passed
  // through a wall of the map is counted (a wrong pose). A scan with no counted hit fits 0.
  // `counted`: the share of the hits counted.
  double fit(const Pose2& pose, const PreparedScan& scan, double distance, bool known_only = false,
             double* counted = nullptr) const;
  // The share of the scan's returns that, cast from `pose`, meet an occupied cell of the map more
  // than `margin` + `fraction` of their range before their end: the laser saw through a wall the
  // map puts there.
  double see_through(const Pose2& pose, const PreparedScan& scan, double margin, double fraction) const;

  const LaserModelConfig& config() const { return config_; }
  size_t table_size() const { return table_.size(); }  // entries: one per DistanceField code
  // For the next prepare(): the configured model, or while the filter searches (lost, uncertain)
  // AMCL's likelihood_field (1 + sum pz^3) with a wider field.
  void set_search(bool search, double sigma_hit);
  LaserModelType type() const { return type_; }

 private:
  // pz of the field at a beam end `distance` from the nearest obstacle, in a known or unknown cell.
  double hit_density(double distance, bool unknown, double z_max, double sigma_hit) const;
  double beam_pz(double measured, double expected, double z_max) const;
  // Whether the ray from `start` (grid cell units) along `angle` meets an occupied cell within
  // `end` cells.
  bool meets_wall(const Eigen::Vector2d& start, double angle, double end) const;

  std::shared_ptr<const SharedMap> map_;
  LaserModelConfig config_;
  LaserModelType type_;  // in use: config_.type, or likelihood_field while searching
  double sigma_hit_;     // in use
  double table_z_max_ = -1.0;
  std::vector<float> end_x_, end_y_;  // the prepared scan's hits, cell units, base_link
  struct FieldEntry {
    float term;     // pz^3, or log pz, at sigma_hit_
    float measure;  // pz at the configured sigma_hit
  };
  std::vector<FieldEntry> table_;  // by DistanceField code (distance units, unknown bit)
};

}  // namespace locd::grid_mcl
