// The emoi_markov localizer: configuration errors, bad input, and a short run on a small world.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "localizer.hpp"
#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sdk/geometry.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sim_emoi_markov/four_positions.hpp"

namespace {

namespace fs = std::filesystem;
using namespace locd;
using namespace locd::emoi;
namespace sim = locd::sim::emoi;

struct SmallWorld {
  fs::path directory = fs::temp_directory_path() / ("emoi_localizer_test_" + std::to_string(::getpid()));
  SmallWorld() {
    fs::create_directories(directory);
    sim::SyntheticDsmConfig config;
    config.size_x_m = config.size_y_m = 60.0;
    config.resolution_m = 0.2;
    config.buildings = 4;
    config.walls = 4;
    config.trees = 10;
    write_dsm_geotiff(sim::generate_world(config, 3).surface, directory / "small.tif");
  }
  ~SmallWorld() { fs::remove_all(directory); }
  PluginContext context(size_t max_cells = 50'000'000) const {
    PluginContext c;
    c.robot_id = "robot1";
    c.maps = MapResolver({directory});
    c.limits.max_map_cells = max_cells;
    return c;
  }
};

Params params_of(const std::string& yaml) { return split_plugin_config(yaml, "test").params; }

std::string config_error(EmoiMarkovLocalizer& localizer, const PluginContext& context, const std::string& yaml) {
  try {
    localizer.configure(context, params_of(yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

const char* kGood = "plugin: emoi_markov\nparams:\n  map: small.tif\n  radii_m: [3, 6]\n  cache: false\n";

TEST(EmoiMarkovConfig, EveryBadParameterIsNamedWithWhatIsAllowed) {
  SmallWorld world;
  EmoiMarkovLocalizer localizer;
  const auto context = world.context();
  std::string e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  sigma_m: -1\n");
  EXPECT_NE(e.find("emoi_markov.sigma_m"), std::string::npos) << e;
  EXPECT_NE(e.find("-1"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  shape_sigma_m: -0.2\n");
  EXPECT_NE(e.find("emoi_markov.shape_sigma_m"), std::string::npos) << e;
  EXPECT_NE(e.find("-0.2"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  heading_source: compass\n");
  EXPECT_NE(e.find("heading_source"), std::string::npos) << e;
  EXPECT_NE(e.find("imu"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  sigma: 0.1\n");
  EXPECT_NE(e.find("sigma"), std::string::npos) << e;
  e = config_error(localizer, context,
                   "plugin: emoi_markov\nparams:\n  map: small.tif\n  min_coverage: 0.8\n  full_coverage: 0.5\n");
  EXPECT_NE(e.find("full_coverage"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  radii_m: [5]\n");
  EXPECT_NE(e.find("map"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  distortion_nodes: 4\n");
  EXPECT_NE(e.find("emoi_markov.distortion_nodes"), std::string::npos) << e;
  EXPECT_NE(e.find("odd"), std::string::npos) << e;
  e = config_error(localizer, context, "plugin: emoi_markov\nparams:\n  map: small.tif\n  distortion_support_mass: 0\n");
  EXPECT_NE(e.find("distortion_support_mass"), std::string::npos) << e;
}

TEST(EmoiMarkovConfig, MapsResolveOnlyInsideTheMapDirectoriesAndAreBounded) {
  SmallWorld world;
  EmoiMarkovLocalizer localizer;
  EXPECT_NE(config_error(localizer, world.context(), "plugin: emoi_markov\nparams:\n  map: ../small.tif\n").find(".."),
            std::string::npos);
  EXPECT_NE(config_error(localizer, world.context(), "plugin: emoi_markov\nparams:\n  map: /etc/passwd\n").find("absolute"),
            std::string::npos);
  EXPECT_NE(config_error(localizer, world.context(), "plugin: emoi_markov\nparams:\n  map: none.tif\n").find("not found"),
            std::string::npos);
  EXPECT_NE(config_error(localizer, world.context(1000), kGood).find("max_map_cells"), std::string::npos);
  const std::string too_big =
      config_error(localizer, world.context(), "plugin: emoi_markov\nparams:\n  map: small.tif\n  radii_m: [40]\n  cache: false\n");
  EXPECT_NE(too_big.find("does not fit"), std::string::npos) << too_big;
  EXPECT_EQ(config_error(localizer, world.context(), kGood), "");
}

TEST(EmoiMarkovInput, BadMeasurementsAreRejectedAndTheSessionGoesOn) {
  SmallWorld world;
  EmoiMarkovLocalizer localizer;
  localizer.configure(world.context(), params_of(kGood));
  LaserScan scan;
  scan.ranges.assign(10, 5.0f);
  scan.range_max = 80.0f;
  scan.angle_increment = 0.1f;
  EXPECT_THROW(localizer.update(scan), InputError);  // no odometry yet
  Odometry odometry;
  odometry.header.stamp_ns = 1000;
  EXPECT_NO_THROW(localizer.update(odometry));
  // Stamps going backwards, NaN poses, bad attitudes and oversized scans never reach the plugin:
  // the session and the bridge refuse them (tests/sdk/validate_test.cpp, tests/server).
  EXPECT_THROW(localizer.update(Image{}), InputError);
  PoseEstimate outside;
  outside.pose.translation() << 500.0, 5.0, 0.0;
  try {
    localizer.set_pose(outside);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("outside the DSM"), std::string::npos) << e.what();
  }
  scan.ranges[3] = std::nanf("");  // one NaN beam: counted, the scan is used
  EXPECT_NO_THROW(localizer.update(scan));
  EXPECT_NO_THROW(localizer.update(odometry));  // still running
}

TEST(EmoiMarkovInput, InitialPoseGivesAGaussianBelief) {
  SmallWorld world;
  EmoiMarkovLocalizer localizer;
  localizer.configure(world.context(), params_of(std::string(kGood) + "  use_initial_pose: true\n"));
  PoseEstimate pose;
  pose.pose = isometry_from_xyz_rpy(20.0, 30.0, 0.0, 0.0, 0.0, 0.3);
  pose.covariance = Matrix6d::Identity();
  localizer.set_pose(pose);
  const auto summary = localizer.filter().grid().summary();
  EXPECT_NEAR(summary.mode.x(), 20.0, 0.2);
  EXPECT_NEAR(summary.mode.y(), 30.0, 0.2);
  EXPECT_NEAR(summary.covariance(0, 0), 1.0, 0.1);
}

// The localization state: lost with every pose until the first sensor update of a global
// belief; an initial pose is judged at once (a 3 m one: uncertain, most of it beyond 1 m); the
// new parameters are range-checked.
TEST(EmoiMarkovState, LostUntilTheFirstSensorUpdateAndAnInitialPoseJudged) {
  SmallWorld world;
  EmoiMarkovLocalizer global;
  global.configure(world.context(), params_of(kGood));
  Odometry odometry;
  odometry.header.stamp_ns = 1000;
  const UpdateResult first = global.update(odometry);
  ASSERT_TRUE(first.localization.has_value());
  EXPECT_EQ(first.localization->state, LocalizationState::kLost);
  EXPECT_NE(first.localization->reason.find("no sensor update yet"), std::string::npos) << first.localization->reason;

  EmoiMarkovLocalizer tracking;
  tracking.configure(world.context(), params_of(std::string(kGood) + "  use_initial_pose: true\n"));
  PoseEstimate pose;
  pose.pose = isometry_from_xyz_rpy(20.0, 30.0, 0.0, 0.0, 0.0, 0.0);
  pose.covariance = Matrix6d::Identity() * 9.0;
  tracking.set_pose(pose);
  const UpdateResult after = tracking.update(odometry);
  ASSERT_TRUE(after.localization.has_value());
  EXPECT_EQ(after.localization->state, LocalizationState::kUncertain) << after.localization->reason;
  EXPECT_NE(after.localization->reason.find("tracking_mass"), std::string::npos) << after.localization->reason;

  EmoiMarkovLocalizer bad;
  std::string e = config_error(bad, world.context(), std::string(kGood) + "  tracking_mass: 1.5\n");
  EXPECT_NE(e.find("emoi_markov.tracking_mass"), std::string::npos) << e;
  e = config_error(bad, world.context(), std::string(kGood) + "  max_fit_rms_m: 0\n");
  EXPECT_NE(e.find("emoi_markov.max_fit_rms_m"), std::string::npos) << e;
  e = config_error(bad, world.context(), std::string(kGood) + "  shape_edge_step_m: -1\n");
  EXPECT_NE(e.find("emoi_markov.shape_edge_step_m"), std::string::npos) << e;
}

// A short drive on a small world from a rough initial pose (3 m): every sensor update returns a
// pose, the belief grid and diagnostics; the belief stays normalised, and after the last update
// the estimate is near the truth and most of the belief within 2 m of it.
TEST(EmoiMarkovRun, ShortDriveOnASmallWorld) {
  sim::FourPositionsScenario scenario;
  scenario.world.size_x_m = scenario.world.size_y_m = 60.0;
  scenario.world.resolution_m = 0.2;
  scenario.world.buildings = 4;
  scenario.world.walls = 4;
  scenario.world.trees = 10;
  scenario.path = {{15, 20}, {27, 20}, {35, 30}, {35, 42}};
  scenario.laser.rate_hz = 5.0;
  scenario.laser.beams = 91;
  scenario.odometry.scale_stddev = 0.03;
  scenario.odometry.drift_stddev_rad = 0.01;
  const auto run = sim::build_run(scenario, 11);
  EmoiMarkovLocalizer localizer;
  EmoiMarkovConfig config;
  config.map = "in-memory";
  config.radii_m = {3.0, 6.0};
  config.update_distance_m = 10.0;
  config.heading_source = "imu";
  config.cache = false;
  config.match_resolution_m = 0.2;
  config.sensor.min_coverage = 0.05;
  config.sensor.full_coverage = 0.5;
  config.base_height_m = scenario.base_height_m;
  config.local_map.size_m = 4 * 6.0 + 20;
  config.use_initial_pose = true;
  localizer.configure(PluginContext{}, config, run.dsm);
  PoseEstimate start;
  start.pose = isometry_from_xyz_rpy(17.0, 18.0, 0.0, 0.0, 0.0, 0.0);  // truth (15, 20)
  start.covariance = Matrix6d::Identity() * 9.0;
  localizer.set_pose(start);
  double last_error = 1e9;
  std::vector<double> truth_probability;
  size_t updates = 0, with_hypotheses = 0;
  sim::simulate_measurements(scenario, run, 11, [&](const Measurement& m, const Eigen::Isometry3d& truth) {
    const auto before = localizer.filter().sensor_updates();
    const UpdateResult out = localizer.update(m);
    if (localizer.filter().sensor_updates() == before) return false;
    ++updates;
    EXPECT_TRUE(out.estimate.has_value());
    EXPECT_TRUE(out.grid.has_value());
    EXPECT_TRUE(out.estimate->covariance.allFinite());
    // Every sensor update judges the belief and says why, with the criteria in the diagnostics.
    EXPECT_TRUE(out.localization.has_value());
    if (out.localization) {
      EXPECT_FALSE(out.localization->reason.empty());
    }
    int criteria = 0;
    for (const auto& [name, value] : out.diagnostics.values) {
      criteria += name == "modes" || name == "belief_area_m2" || name == "peak_mass" ? 1 : 0;
    }
    EXPECT_EQ(criteria, 3);
    EXPECT_NEAR(cv::sum(localizer.filter().grid().belief())[0], 1.0, 1e-4);
    // The belief starts concentrated (initial pose): the distortion hypotheses run on its support.
    const DistortionReport& distortion = localizer.filter().last_distortion();
    if (distortion.cells > 0) {
      ++with_hypotheses;
      double total = 0.0;
      for (double p : distortion.posterior) total += p;
      EXPECT_NEAR(total, 1.0, 1e-9);
      EXPECT_EQ(distortion.posterior.size(), 25u);
    }
    // Belief mass within 2 m of the truth.
    const auto& g = localizer.filter().grid().geometry();
    const auto& belief = localizer.filter().grid().belief();
    double near_truth = 0.0;
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c)
        if ((g.center_of(r, c) - truth.translation().head<2>()).norm() < 2.0) near_truth += belief(r, c);
    truth_probability.push_back(near_truth);
    last_error = (out.estimate->pose.translation().head<2>() - truth.translation().head<2>()).norm();
    return false;
  });
  EXPECT_GE(updates, 3u);
  EXPECT_GE(with_hypotheses, 1u);
  ASSERT_FALSE(truth_probability.empty());
  EXPECT_GT(truth_probability.back(), 0.1);  // a uniform belief would hold 12.6 / 3600 = 0.0035
  EXPECT_LT(last_error, 2.0);
}

}  // namespace

namespace {

// The shipped example config and its DSM (config/maps/emoi_hills.yaml, a PNG sidecar) load.
TEST(EmoiMarkovConfig, ShippedConfigAndMapLoad) {
  const fs::path source = std::getenv("LOCD_SOURCE_DIR") ? std::getenv("LOCD_SOURCE_DIR") : ".";
  std::ifstream in(source / "config/plugins/emoi_markov.yaml");
  ASSERT_TRUE(in) << "config/plugins/emoi_markov.yaml not found under " << source;
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  const PluginConfig config = split_plugin_config(text, "emoi_markov.yaml");
  EXPECT_EQ(config.plugin, "emoi_markov");
  PluginContext context;
  context.maps = MapResolver({source / "config/maps"});
  EmoiMarkovLocalizer localizer;
  ASSERT_NO_THROW(localizer.configure(context, config.params));
  EXPECT_EQ(localizer.filter().grid().geometry().width, 300);
  EXPECT_NEAR(localizer.filter().grid().geometry().resolution, 0.2, 1e-12);
  EXPECT_NE(localizer.filter().matcher(), nullptr);
}

}  // namespace
