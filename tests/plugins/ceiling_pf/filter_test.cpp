// The particle filter: association on an ambiguous layout (Table 1), unbiased low-variance
// resampling, the KLD bound, frames with zero or one detection, global localization on a small
// map and recovery from a kidnapping (augmented MCL).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "locd/ceiling_pf/ceiling_particle_filter.hpp"
#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/resampling.hpp"
#include "locd/sim_ceiling_pf/hall_drive.hpp"

using namespace locd;
using namespace locd::ceiling_pf;
namespace simc = locd::sim::ceiling;

namespace {

std::vector<Detection> detections_from(const Pose2& robot, const std::vector<Eigen::Vector2d>& landmarks,
                                       const std::vector<int>& seen) {
  std::vector<Detection> out;
  for (int i : seen) out.push_back(Detection::from_point(robot.inverse().transform(landmarks[i])));
  return out;
}

std::vector<Eigen::Vector2d> square_grid(int n, double spacing) {
  std::vector<Eigen::Vector2d> g;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) g.emplace_back(c * spacing, r * spacing);
  return g;
}

}  // namespace

TEST(CeilingPfAssociation, PicksTheMostLikelyOfTheNearestOnAnAmbiguousGrid) {
  const auto grid = square_grid(6, 3.0);  // identical landmarks every 3 m: every cell looks alike
  auto index = std::make_shared<NearestLandmarkIndex>(grid, 3, 0.5, 4.0, 1'000'000);
  ParticleFilterConfig config;
  const CeilingParticleFilter filter(config, index, VelocityMotionModel());
  const Pose2 truth(4.5, 4.2, 0.1);
  // Landmarks (3,3), (6,3), (3,6), (6,6) are indices 7, 8, 13, 14.
  const std::vector<int> seen{7, 8, 13, 14};
  const std::vector<Detection> z = detections_from(truth, grid, seen);
  std::vector<Association> a;
  const double at_truth = filter.log_likelihood(truth, z, &a);
  ASSERT_EQ(a.size(), 4u);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].landmark, seen[k]);
    EXPECT_NEAR(a[k].normalized_error2, 0.0, 1e-18);
    EXPECT_EQ(a[k].candidates, 3);
  }
  // One grid step east: the same picture, every detection associated with the shifted landmark.
  const double shifted = filter.log_likelihood(Pose2(7.5, 4.2, 0.1), z, &a);
  EXPECT_NEAR(shifted, at_truth, 1e-9);
  for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].landmark, seen[k] + 1);
  // Half a step off: no landmark fits, every detection falls to the outlier term.
  const double off = filter.log_likelihood(Pose2(6.0, 4.2, 0.1), z, &a);
  EXPECT_LT(off, at_truth - 20.0);
  for (const Association& x : a) EXPECT_EQ(x.landmark, -1);
  // A small pose error keeps the right association, with a lower likelihood.
  const double near = filter.log_likelihood(Pose2(4.55, 4.22, 0.11), z, &a);
  EXPECT_LT(near, at_truth);
  for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].landmark, seen[k]);
}

TEST(CeilingPfAssociation, LikelihoodIsTheProductOfRangeAndBearingGaussians) {
  const std::vector<Eigen::Vector2d> one{{2.0, 0.0}, {50.0, 50.0}};
  auto index = std::make_shared<NearestLandmarkIndex>(one, 1, 0.5, 4.0, 1'000'000);
  ParticleFilterConfig config;
  config.hit_fraction = 1.0;  // no outlier term: eq. 7-9 exactly (with 2 sigma^2 in the exponent)
  config.candidates = 1;
  const CeilingParticleFilter filter(config, index, VelocityMotionModel());
  const Detection z = Detection::from_point(Eigen::Vector2d(2.03, 0.04));
  const double ll = filter.log_likelihood(Pose2(), {z});
  const double sb = std::sqrt(config.bearing_stddev * config.bearing_stddev +
                              config.range_stddev * config.range_stddev / (z.range * z.range));
  // Each detection's factor is divided by its peak 1 / (2 pi sr sb), shared by all particles.
  const double expected = std::log(normal_pdf(z.range - 2.0, config.range_stddev) * normal_pdf(z.bearing, sb) *
                                   2.0 * M_PI * config.range_stddev * sb);
  EXPECT_NEAR(ll, expected, 1e-9);
  double explained = 0.0;
  filter.log_likelihood(Pose2(), {z}, nullptr, &explained);
  EXPECT_NEAR(explained, std::exp(expected), 1e-12);
  EXPECT_NEAR(filter.log_likelihood(Pose2(-0.03, -0.04, 0.0), {z}), 0.0, 1e-6) << "perfect fit";
}

TEST(CeilingPfFilter, FramesWithZeroOrOneDetectionKeepItRunning) {
  const auto grid = square_grid(6, 3.0);
  auto index = std::make_shared<NearestLandmarkIndex>(grid, 3, 0.5, 4.0, 1'000'000);
  ParticleFilterConfig config;
  config.particles = 300;
  config.kld_sampling = false;
  CeilingParticleFilter filter(config, index, VelocityMotionModel());
  filter.set_pose(Pose2(4.5, 4.2, 0.0), Eigen::Vector3d(0.1, 0.1, 0.05).cwiseAbs2().asDiagonal());
  Pose2 truth(4.5, 4.2, 0.0);
  for (int step = 0; step < 100; ++step) {
    const Pose2 next = VelocityMotionModel::move(truth, 0.3, 0.0, 0.0, 0.1);
    filter.predict(velocity_between(truth, next, 0.1));
    truth = next;
    const CorrectionReport empty = filter.correct({});
    EXPECT_EQ(empty.detections, 0u);
    EXPECT_FALSE(empty.resampled);
    if (step % 3 == 0) {
      // One detection: the nearest landmark only.
      int nearest = 0;
      for (int i = 1; i < static_cast<int>(grid.size()); ++i)
        if ((grid[i] - Eigen::Vector2d(truth.x, truth.y)).norm() < (grid[nearest] - Eigen::Vector2d(truth.x, truth.y)).norm()) nearest = i;
      filter.correct(detections_from(truth, grid, {nearest}));
    }
    for (const Particle& p : filter.particles()) ASSERT_TRUE(std::isfinite(p.pose.x) && std::isfinite(p.weight));
  }
  const auto e = filter.estimate();
  ASSERT_TRUE(e.has_value());
  EXPECT_LT(std::hypot(e->pose.x - truth.x, e->pose.y - truth.y), 0.3);
}

namespace {

struct SmallHall {
  simc::CeilingWorldConfig world_config;
  std::unique_ptr<simc::CeilingWorld> world;
  std::unique_ptr<simc::CeilingCameraRenderer> camera;
  std::shared_ptr<NearestLandmarkIndex> index;
  SmallHall() {
    world_config.size = Eigen::Vector2d(24, 16);
    world_config.columns = 8;
    world_config.rows = 5;
    world_config.jitter = 0.7;
    world_config.seed = 21;
    world = std::make_unique<simc::CeilingWorld>(world_config);
    camera = std::make_unique<simc::CeilingCameraRenderer>(simc::CeilingCameraConfig{}, *world);
    index = std::make_shared<NearestLandmarkIndex>(world->landmarks(), 3, 0.5, 6.0, 1'000'000);
  }
  simc::DriveConfig route() const {
    simc::DriveConfig d;
    d.waypoints = {{3, 3}, {21, 3}, {21, 13}, {3, 13}, {3, 3}, {21, 3}, {21, 13}};
    d.return_to_start = false;
    return d;
  }
};

// Drives the route, feeding odometry and noisy on-board detections; returns the final error
// and the first time the error stayed below 0.2 m until the end.
struct DriveOutcome {
  double final_error = 1e9;
  double settled_at = -1.0;
};

DriveOutcome drive(const SmallHall& hall, CeilingParticleFilter& filter, uint64_t seed, double duration,
                   double kidnap_at = -1.0, Eigen::Vector2d kidnap_by = Eigen::Vector2d::Zero()) {
  simc::HallDrive run(hall.route(), *hall.camera, seed, std::nullopt, false);
  std::mt19937_64 noise(seed + 99);
  std::normal_distribution<double> pixel(0.0, 0.01);
  std::optional<Pose2> last_odometry;
  int64_t last_stamp = 0;
  DriveOutcome out;
  bool kidnapped = false;
  while (auto event = run.next(duration)) {
    if (kidnap_at > 0 && !kidnapped && event->t >= kidnap_at) {
      const Pose2 t = run.truth().pose;
      run.teleport(Pose2(t.x + kidnap_by.x(), t.y + kidnap_by.y(), t.theta));
      kidnapped = true;
      out.settled_at = -1.0;
      continue;
    }
    if (const auto* odom = std::get_if<Odometry>(&event->measurement)) {
      const Pose2 p = Pose2::from_isometry(odom->pose);
      if (last_odometry) filter.predict(velocity_between(*last_odometry, p, 1e-9 * (odom->header.stamp_ns - last_stamp)));
      last_odometry = p;
      last_stamp = odom->header.stamp_ns;
    } else if (const auto* frame = std::get_if<LandmarkDetections>(&event->measurement)) {
      std::vector<Detection> z;
      for (const auto& d : frame->detections)
        z.push_back(Detection::from_point(d.position.head<2>() + Eigen::Vector2d(pixel(noise), pixel(noise))));
      filter.correct(z);
    }
    if (const auto e = filter.estimate()) {
      const double err = std::hypot(e->pose.x - event->truth.x, e->pose.y - event->truth.y);
      out.final_error = err;
      if (err < 0.2 && out.settled_at < 0) out.settled_at = event->t;
      if (err >= 0.2) out.settled_at = -1.0;
    }
  }
  return out;
}

}  // namespace

TEST(CeilingPfFilter, GlobalLocalizationConvergesOnASmallMap) {
  const SmallHall hall;
  ParticleFilterConfig config;
  config.max_range = hall.camera->config().fx > 0 ? 4.0 : 4.0;
  config.global_particles = 4000;
  config.max_particles = 4000;
  config.seed = 3;
  int converged = 0;
  for (uint64_t seed : {1u, 2u, 3u}) {
    config.seed = seed;
    CeilingParticleFilter filter(config, hall.index, VelocityMotionModel());
    filter.set_unknown();
    EXPECT_FALSE(filter.estimate().has_value());
    const DriveOutcome out = drive(hall, filter, seed, 60.0);
    if (out.settled_at >= 0.0 && out.final_error < 0.2) ++converged;
    EXPECT_LT(filter.particles().size(), 4000u) << "KLD shrinks the set once converged";
  }
  EXPECT_EQ(converged, 3);
}

TEST(CeilingPfFilter, RecoversFromAKidnapping) {
  const SmallHall hall;
  ParticleFilterConfig config;
  config.max_range = 4.0;
  config.global_particles = 4000;
  config.max_particles = 4000;
  CeilingParticleFilter filter(config, hall.index, VelocityMotionModel());
  filter.set_pose(Pose2(3, 3, 0.0), Eigen::Vector3d(0.1, 0.1, 0.05).cwiseAbs2().asDiagonal());
  const DriveOutcome out = drive(hall, filter, 5, 90.0, 20.0, Eigen::Vector2d(8.0, 5.0));
  EXPECT_LT(out.final_error, 0.2);
  EXPECT_GE(out.settled_at, 20.0);
  EXPECT_LT(out.settled_at, 80.0) << "recovered within 60 s of the kidnapping";
}

TEST(CeilingPfFilter, WithoutRecoveryAKidnappingIsNotRecovered) {
  const SmallHall hall;
  ParticleFilterConfig config;
  config.max_range = 4.0;
  config.recovery = false;
  CeilingParticleFilter filter(config, hall.index, VelocityMotionModel());
  filter.set_pose(Pose2(3, 3, 0.0), Eigen::Vector3d(0.1, 0.1, 0.05).cwiseAbs2().asDiagonal());
  const DriveOutcome out = drive(hall, filter, 5, 90.0, 20.0, Eigen::Vector2d(8.0, 5.0));
  EXPECT_GT(out.final_error, 1.0);
}
