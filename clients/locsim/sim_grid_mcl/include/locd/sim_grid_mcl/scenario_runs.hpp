// Drives a locsim grid scenario through grid_mcl's Localizer in-process (the benchmarks' and the
// tests' runs) (as `locsim run` does,
// every measurement through locd::validate first) and scores every estimate against the truth:
//   tracking   the scenario's initial pose (truth + offset, with its stddev)
//   global     an initial pose whose stddev reaches global_localization_stddev: a uniform start
//   kidnap     at kidnap_at the robot is carried, unseen by its odometry, to where its route would
//              have taken it kidnap_ahead_s later (about that many metres on): from then on the
//              measurements come from a second drive of the same scenario (another seed),
//              fast-forwarded, its odometry continuing the first's without a jump. The filter
//              holds a tight cloud at the wrong place and must notice and relocalize.
#pragma once

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "locd/sdk/validate.hpp"
#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"
#include "localizer.hpp"

namespace locd::sim::grid {

struct RunSpec {
  std::string scenario_file;
  uint64_t seed = 1;
  double duration_s = 60.0;
  bool global = false;
  double kidnap_at = -1.0;
  double kidnap_ahead_s = 20.0;
  std::map<std::string, std::string> params;  // plugin parameters overridden (YAML scalars)
};

struct TraceSample {
  double t = 0.0;
  double error = 0.0;          // m
  double heading_error = 0.0;  // rad
  LocalizationState state = LocalizationState::kUnknown;
  size_t particles = 0;
  std::string reason;
};

struct RunTrace {
  std::vector<TraceSample> samples;  // every estimate
  double update_ms_sum = 0.0;        // scans only
  size_t scans = 0;
  size_t max_particles = 0;
  size_t relocalizations = 0;        // scans on which the filter restarted global localization or
                                     // moved to a confirmed hypothesis
  LocalizationState last_state = LocalizationState::kUnknown;
};


inline RunTrace run_scenario(const RunSpec& spec) {
  const sim::Scenario scenario = sim::load_scenario(spec.scenario_file);
  YAML::Node node = YAML::Clone(scenario.localizer.params.node());
  for (const auto& [key, value] : spec.params) node[key] = YAML::Load(value);
  const Params params(node, scenario.localizer.params.path());
  PluginContext context;
  context.robot_id = scenario.robot.id;
  context.maps = MapResolver(scenario.map_directories);
  grid_mcl::GridMclLocalizer localizer;
  localizer.configure(context, params);
  sim::Simulation first(scenario, spec.seed, spec.duration_s);
  PoseEstimate start = first.initial_pose();
  if (spec.global) start.covariance(0, 0) = start.covariance(1, 1) = 1e8;
  localizer.set_pose(start);
  // After a kidnapping: the second drive, its time and odometry mapped onto the first's.
  std::unique_ptr<sim::Simulation> second;
  double second_offset = 0.0;
  Pose2 odometry_at_kidnap, second_odometry_origin;
  bool second_odometry_seen = false;
  Pose2 last_odometry;
  RunTrace trace;
  LocalizationState state = LocalizationState::kUnknown;
  std::string reason;
  for (;;) {
    std::optional<sim::SimulatedMeasurement> m;
    double t = 0.0;
    Pose2 truth;
    if (!second) {
      m = first.next();
      if (!m) break;
      t = m->t;
      if (spec.kidnap_at >= 0.0 && t >= spec.kidnap_at) {
        second_offset = -spec.kidnap_ahead_s;
        second = std::make_unique<sim::Simulation>(scenario, spec.seed + 1000, spec.duration_s + spec.kidnap_ahead_s,
                                                   first.stamp_of(second_offset));
        odometry_at_kidnap = last_odometry;
        continue;
      }
      truth = first.truth().at(t).pose;
    } else {
      m = second->next();
      if (!m) break;
      if (m->t < spec.kidnap_at + spec.kidnap_ahead_s) continue;  // fast-forward
      t = second_offset + m->t;
      truth = second->truth().at(m->t).pose;
      if (auto* o = std::get_if<Odometry>(&m->measurement)) {
        const Pose2 raw = Pose2::from_isometry(o->pose);
        if (!second_odometry_seen) {
          second_odometry_origin = raw;
          second_odometry_seen = true;
        }
        o->pose = (odometry_at_kidnap * (second_odometry_origin.inverse() * raw)).to_isometry();
      }
    }
    if (const auto* o = std::get_if<Odometry>(&m->measurement)) last_odometry = Pose2::from_isometry(o->pose);
    validate(m->measurement);
    const bool scan = std::holds_alternative<LaserScan>(m->measurement);
    const auto begin = std::chrono::steady_clock::now();
    const UpdateResult r = localizer.update(m->measurement);
    if (scan) {
      trace.update_ms_sum += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
      ++trace.scans;
      trace.max_particles = std::max(trace.max_particles, localizer.filter().particles().size());
    }
    if (r.localization) {
      state = r.localization->state;
      reason = r.localization->reason;
      if (reason.find("relocalization") != std::string::npos) ++trace.relocalizations;
    }
    if (!r.estimate) continue;
    const Pose2 e = Pose2::from_isometry(r.estimate->pose);
    trace.samples.push_back({t, std::hypot(e.x - truth.x, e.y - truth.y), std::abs(normalize_angle(e.theta - truth.theta)),
                             state, localizer.filter().particles().size(), reason});
  }
  trace.last_state = state;
  return trace;
}

// First time from which the error stays below threshold until `until`; -1 if never.
inline double settled_time(const RunTrace& trace, double threshold, double from, double until) {
  double settled = -1.0;
  for (const TraceSample& s : trace.samples) {
    if (s.t < from || s.t > until) continue;
    if (s.error < threshold) {
      if (settled < 0.0) settled = s.t;
    } else {
      settled = -1.0;
    }
  }
  return settled;
}

// RMSE of the position error over [from, until].
inline double rmse(const RunTrace& trace, double from, double until = 1e18) {
  double sum = 0.0;
  size_t n = 0;
  for (const TraceSample& s : trace.samples) {
    if (s.t < from || s.t > until) continue;
    sum += s.error * s.error;
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : NAN;
}

inline double mean(const std::vector<double>& v) {
  return v.empty() ? NAN : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

}  // namespace locd::sim::grid
