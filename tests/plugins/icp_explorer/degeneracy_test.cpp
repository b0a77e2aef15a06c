// Degeneracy-aware registration and its covariance, on synthetic scenes:
// - an endless corridor (no end walls): the axis is found poorly constrained and held to the
//   prior, the other directions follow the data, the projector picks the axis;
// - the covariance sigma^2 H^+ of a well-constrained scan against the spread of the registration
//   over many noise draws (its moments);
// - the plugin (the .so) driven through the two-rooms-and-corridor world: the error along the
//   corridor's axis within the reported 3 sigma (all but one of 48 scans; none beyond 4), the axis held to odometry in most
//   of the corridor's middle and its sigma there that of odometry, no degenerate direction in
//   the rooms.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

#include "locd/icp_explorer/modified_icp.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sim_icp_explorer/stop_and_scan_path.hpp"
#include "test_env.hpp"
#include "toy_world.hpp"

namespace ie = locd::icp_explorer;
using locd::Pose2;

namespace {

// A corridor along x from -40 to 40 m, 2 m wide, 2.6 m high: no end within the scanner's 20 m.
locd::sim::IndoorWorld endless_corridor() {
  std::vector<locd::sim::SurfaceBox> b;
  auto add = [&](Eigen::Vector3d lo, Eigen::Vector3d hi) { b.push_back({Eigen::AlignedBox3d(lo, hi), 0.5f, "wall"}); };
  add({-40, -1.2, -0.2}, {40, 1.2, 0});
  add({-40, -1.2, 2.6}, {40, 1.2, 2.8});
  add({-40, -1.2, 0}, {40, -1.0, 2.6});
  add({-40, 1.0, 0}, {40, 1.2, 2.6});
  return locd::sim::IndoorWorld(std::move(b), {});
}

ie::RejectionRules rules_for(double max_range) {
  ie::RejectionRules r;
  r.max_range = max_range;
  return r;
}

double value(const locd::Diagnostics& d, const std::string& name) {
  for (const auto& [n, v] : d.values)
    if (n == name) return v;
  return -1.0;
}

}  // namespace

TEST(Degeneracy, EndlessCorridorHoldsTheAxisToThePriorAndAlignsTheRest) {
  const auto world = endless_corridor();
  const locd::sim::Scanner3D scanner(locd::sim::Scanner3DConfig{});  // full size: 720 x 140 rays
  // The corridor mapped from x = -12 to 12, so no end of the map lies within the new scan's reach
  // (the edge of what was mapped pins a scan along the axis as an end wall would).
  ie::VoxelMap model(0.1);
  for (double x : {-12.0, 0.0, 12.0}) {
    const Eigen::Isometry3d model_pose = Pose2(x, 0.0, 0.0).to_isometry();
    model.insert(locd::test::scan_in_map(world, scanner, model_pose, 0.1, 1),
                 (model_pose * scanner.sensor_in_base()).translation());
  }
  const Eigen::Isometry3d truth = Pose2(2.0, 0.1, 0.05).to_isometry();
  const ie::ScanPoints data = ie::transformed(locd::test::scan_in_map(world, scanner, truth, 0.3, 2), truth.inverse());
  // The prior is off by 0.4 m along the axis, 0.15 m across it and 4 degrees.
  const Eigen::Isometry3d prior = truth * Pose2(0.4, -0.15, 4.0 * M_PI / 180).to_isometry();
  const ie::CorrespondenceRejector rejector(rules_for(20.0), ie::OdometryErrorBound{}, prior, scanner.sensor_in_base());
  const ie::RegistrationResult r = ie::register_scan(data, model, prior, rejector, ie::IcpSettings{});

  EXPECT_EQ(r.degenerate_directions, 1) << r.constraint_shares.transpose();
  // The poorly constrained direction is the translation along the corridor (z's first axis).
  EXPECT_GT(std::abs(r.directions(0, 0)), 0.95) << r.directions.col(0).transpose();
  EXPECT_LT(r.constraint_shares(0), ie::DegeneracySettings{}.min_constraint_share);
  EXPECT_GT(r.constraint_shares(1), 0.05);
  // Along the axis the pose stays where the prior put it; across it and in yaw the data rule.
  EXPECT_NEAR(r.T_map_base.translation().x(), prior.translation().x(), 0.01);
  EXPECT_NEAR(r.T_map_base.translation().y(), truth.translation().y(), 0.02);
  EXPECT_NEAR(locd::yaw_of(r.T_map_base.linear()), 0.05, 0.2 * M_PI / 180);
  EXPECT_TRUE(r.converged) << r.verdict;
  // The projector keeps a displacement along the axis (at the scanner) and removes one across it.
  const Eigen::Vector3d scanner_in_map = r.T_map_base * scanner.sensor_in_base().translation();
  ie::Vector6d along = ie::Vector6d::Zero(), across = ie::Vector6d::Zero();
  along(0) = 1.0;
  across(1) = 1.0;
  const ie::Matrix6d M = ie::local_to_xi(scanner_in_map, Eigen::Matrix3d::Identity());
  EXPECT_LT((r.degenerate_projector * M * along - M * along).norm(), 0.05);
  EXPECT_LT((r.degenerate_projector * M * across).norm(), 0.05);
  // The registration's own covariance says nothing about the axis (the prior's will).
  EXPECT_LT(r.covariance(0, 0), 1e-4);
}

// sigma^2 H^+ against the registration's spread over noise draws: a scan of the two-room toy
// world with 1 cm range noise, registered from the truth to a noise-free model, 40 draws.
TEST(Degeneracy, HessianCovarianceMatchesTheSpreadOverNoiseDraws) {
  const auto world = locd::test::two_rooms();
  locd::sim::Scanner3DConfig noise_free = locd::test::coarse_scanner();
  noise_free.range_stddev = 0.0;
  locd::sim::Scanner3DConfig noisy = locd::test::coarse_scanner();
  noisy.range_stddev = 0.01;
  const locd::sim::Scanner3D clean(noise_free), scanner(noisy);
  ie::VoxelMap model(0.05);
  const Eigen::Isometry3d model_pose = Pose2(2.5, 1.5, 0.0).to_isometry();
  model.insert(locd::test::scan_in_map(world, clean, model_pose, 0.05, 1), (model_pose * clean.sensor_in_base()).translation());
  const Eigen::Isometry3d truth = Pose2(3.0, 2.0, 0.3).to_isometry();
  const ie::CorrespondenceRejector rejector(rules_for(15.0), ie::OdometryErrorBound{}, truth, scanner.sensor_in_base());
  const int draws = 40;
  ie::Matrix6d empirical = ie::Matrix6d::Zero(), reported = ie::Matrix6d::Zero();
  for (int k = 0; k < draws; ++k) {
    const ie::ScanPoints data =
        ie::transformed(locd::test::scan_in_map(world, scanner, truth, 0.3, 100 + static_cast<uint64_t>(k)), truth.inverse());
    const ie::RegistrationResult r = ie::register_scan(data, model, truth, rejector, ie::IcpSettings{});
    ASSERT_EQ(r.degenerate_directions, 0);
    const ie::Vector6d e = ie::se3_log(r.T_map_base * truth.inverse());
    empirical += e * e.transpose() / draws;
    reported += r.covariance / draws;
  }
  // Compare at the scanner (translation there, rotation). The reported variance must not be below
  // the spread (40 draws give it to about +-25 %, hence the factor 2) nor be uselessly large: it
  // is conservative by 2-4x here, since sigma^2 also holds the residuals of voxels on edges and
  // corners, which are the same in every draw and so do not spread the result.
  const Eigen::Vector3d c = truth * scanner.sensor_in_base().translation();
  ie::Matrix6d N = ie::Matrix6d::Identity();
  N.topRightCorner<3, 3>() = -ie::skew(c);
  const ie::Matrix6d E = N * empirical * N.transpose(), R = N * reported * N.transpose();
  for (int a : {0, 1, 5}) {  // x, y, yaw: what a ground robot uses
    EXPECT_GT(R(a, a), E(a, a) / 2.0) << "axis " << a << " reported " << R(a, a) << " empirical " << E(a, a);
    EXPECT_LT(R(a, a), E(a, a) * 10.0) << "axis " << a << " reported " << R(a, a) << " empirical " << E(a, a);
  }
}

TEST(Degeneracy, CorridorPathErrorAlongTheAxisWithinThreeSigma) {
  const auto library =
      locd::PluginLibrary::open(std::filesystem::path(locd::test::plugin_dir()) / "liblocd_icp_explorer.so");
  const auto world = locd::sim::IndoorWorld::load(locd::test::source_dir() + "/config/maps/two_rooms_corridor_3d.yaml");
  std::ifstream file(locd::test::source_dir() + "/config/plugins/icp_explorer_corridor.yaml");
  std::stringstream text;
  text << file.rdbuf();
  const locd::PluginConfig config = locd::split_plugin_config(text.str(), "icp_explorer_corridor.yaml");
  YAML::Node params = YAML::Clone(config.params.node());
  params["exploration"]["enabled"] = false;
  const locd::sim::Scanner3DConfig scanner;  // the scenario's: 720 x 140 rays
  const auto stops = locd::sim::two_rooms_corridor_stops();
  int middle_scans = 0, middle_held = 0, scans = 0, within_3_sigma = 0;
  for (uint64_t seed : {1u, 2u, 3u}) {
    const auto localizer = locd::create_configured(*library, locd::PluginContext{}, locd::Params(params, "icp_explorer"));
    const auto records = locd::sim::run_stop_and_scan_path(world, scanner, {}, stops, seed, *localizer);
    ASSERT_EQ(records.size(), stops.size());
    for (size_t k = 1; k < records.size(); ++k) {
      const auto& r = records[k];
      ASSERT_TRUE(r.estimate && r.localization);
      const auto e = locd::sim::pose_error(*r.estimate, r.truth);
      const double sigma_x = std::sqrt(r.estimate->covariance(0, 0));
      // 3 sigma holds 99.7 % of a Gaussian: at most one of the 48 scans beyond it, none beyond 4 sigma.
      within_3_sigma += std::abs(e[0]) <= 3.0 * sigma_x;
      ++scans;
      EXPECT_LE(std::abs(e[0]), 4.0 * sigma_x) << "seed " << seed << " at x " << r.truth.x << ": " << e[0] << " m, sigma "
                                               << sigma_x << "; " << r.localization->reason;
      EXPECT_LE(std::abs(e[1]), 3.0 * std::sqrt(r.estimate->covariance(1, 1)) + 0.01) << "seed " << seed << " at x " << r.truth.x;
      EXPECT_NE(r.localization->state, locd::LocalizationState::kLost) << r.localization->reason;
      const double degenerate = value(r.diagnostics, "degenerate_directions");
      if (r.truth.x > 30.0 && r.truth.x < 46.0) {  // neither end within 20 m: the plugin knows
        EXPECT_GT(sigma_x, 0.2) << "seed " << seed << " at x " << r.truth.x;
        middle_held += degenerate >= 1.0;
        ++middle_scans;
      }
      if (r.truth.x < 8.0 || r.truth.x > 68.0) {
        EXPECT_EQ(degenerate, 0.0) << "seed " << seed << " at x " << r.truth.x;
      }
    }
  }
  EXPECT_GE(within_3_sigma, scans - 1) << within_3_sigma << " of " << scans << " scans within 3 sigma along the axis";
  EXPECT_GE(middle_scans, 9);
  EXPECT_GE(middle_held, middle_scans / 2) << "the axis held to odometry in most of the corridor's middle";
}
