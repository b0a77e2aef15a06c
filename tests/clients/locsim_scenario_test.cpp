#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "locd/sim/scenario.hpp"
#include "locd/sim/simulation.hpp"
#include "locsim_paths.hpp"

namespace fs = std::filesystem;
using locd::ConfigError;
using locd::sim::parse_scenario;

namespace {

// A scratch tree: <tmp>/maps/corridor.yaml, <tmp>/plugins/ekf.yaml, scenarios parsed from <tmp>/scenarios.
class ScenarioFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device random;
    root_ = fs::temp_directory_path() / ("locsim_scenario_" + std::to_string(random()));
    fs::create_directories(root_ / "maps");
    fs::create_directories(root_ / "plugins");
    fs::create_directories(root_ / "scenarios");
    fs::copy_file(locd::sim::test::source_dir() + "/config/maps/corridor.yaml", root_ / "maps" / "corridor.yaml");
    std::ofstream(root_ / "plugins" / "ekf.yaml") << "plugin: feature_ekf\nparams:\n  map: corridor.yaml\n";
  }
  void TearDown() override { fs::remove_all(root_); }

  std::string scenario(const std::string& robot_extra = "", const std::string& top_extra = "",
                       const std::string& map = "corridor.yaml") const {
    return "name: test\nseed: 3\nduration_s: 5\nmap: " + map + "\n" + top_extra +
           "robot:\n  id: bot\n  start: [3, 1, 0]\n  waypoints: [[1, 1], [39, 1]]\n" + robot_extra +
           "sensors:\n  odometry: {rate_hz: 50}\n  laser: {rate_hz: 25}\n"
           "localizer:\n  config_file: ../plugins/ekf.yaml\n  initial_pose_offset: [0.1, 0, 0]\n";
  }
  std::string error_of(const std::string& text) const {
    try {
      const auto s = parse_scenario(text, "test.yaml", root_ / "scenarios");
      locd::sim::Simulation simulation(s, s.seed, s.duration_s);  // validates the sensors
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  fs::path root_;
};

}  // namespace

TEST_F(ScenarioFiles, ParsesAValidScenario) {
  const auto s = parse_scenario(scenario(), "test.yaml", root_ / "scenarios");
  EXPECT_EQ(s.name, "test");
  EXPECT_EQ(s.seed, 3u);
  EXPECT_EQ(s.robot.id, "bot");
  EXPECT_EQ(s.robot.waypoints.size(), 2u);
  EXPECT_EQ(s.localizer.plugin, "feature_ekf");
  EXPECT_EQ(s.localizer.params.path(), "feature_ekf");
  EXPECT_EQ(s.localizer.params.required_text("map"), "corridor.yaml");
  EXPECT_EQ(fs::canonical(s.map_file), fs::canonical(root_ / "maps" / "corridor.yaml"));
  EXPECT_GT(s.map.lines.size(), 40u);
  EXPECT_DOUBLE_EQ(s.localizer.initial_pose_offset.x, 0.1);
  EXPECT_EQ(error_of(scenario()), "");
}

TEST_F(ScenarioFiles, ErrorsNameTheKey) {
  EXPECT_NE(error_of(scenario("  max_speed: 50\n")).find("'robot.max_speed'"), std::string::npos);
  EXPECT_NE(error_of(scenario("  max_speed: 50\n")).find("allowed: (0, 10]"), std::string::npos);
  EXPECT_NE(error_of(scenario("  waypoints_typo: 1\n")).find("unknown parameter 'robot.waypoints_typo'"),
            std::string::npos);
  EXPECT_NE(error_of(scenario("", "colour: red\n")).find("unknown parameter 'colour'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "", "../maps/corridor.yaml")).find("parameter 'map'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "", "../maps/corridor.yaml")).find("'..'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "", "nowhere.yaml")).find("parameter 'map'"), std::string::npos);

  std::string text = scenario();
  text.replace(text.find("laser: {rate_hz: 25}"), 20, "laser: {beams: 1}");
  EXPECT_NE(error_of(text).find("'sensors.laser.beams'"), std::string::npos) << error_of(text);
  text = scenario();
  text.replace(text.find("laser: {rate_hz: 25}"), 20, "sonar: {rate_hz: 5}");
  EXPECT_NE(error_of(text).find("unknown parameter 'sensors.sonar'"), std::string::npos) << error_of(text);
  text = scenario();
  text.replace(text.find("odometry: {rate_hz: 50}"), 23, "odometry: {drift: {translation_fraction: -1}}");
  EXPECT_NE(error_of(text).find("'sensors.odometry.drift.translation_fraction'"), std::string::npos) << error_of(text);
  text = scenario();
  text.replace(text.find("[0.1, 0, 0]"), 11, "[0.1, 0]");
  EXPECT_NE(error_of(text).find("'localizer.initial_pose_offset'"), std::string::npos) << error_of(text);
  text = scenario();
  text.replace(text.find("ekf.yaml"), 8, "missing.yaml");
  EXPECT_NE(error_of(text).find("'localizer.config_file'"), std::string::npos) << error_of(text);
  text = scenario();
  text.replace(text.find("id: bot"), 7, "id: [1]");
  EXPECT_NE(error_of(text).find("'robot.id'"), std::string::npos) << error_of(text);
  EXPECT_NE(error_of("name: x\nrobot: [\n").find("line"), std::string::npos);
}

TEST_F(ScenarioFiles, BadLocalizerConfigNamesTheFile) {
  std::ofstream(root_ / "plugins" / "ekf.yaml") << "plugin: feature_ekf\nparameters: {}\n";
  const std::string error = error_of(scenario());
  EXPECT_NE(error.find("parameters"), std::string::npos) << error;
  EXPECT_NE(error.find("ekf.yaml"), std::string::npos) << error;
}

TEST_F(ScenarioFiles, SimulationStreamsInStampOrderAtTheConfiguredRates) {
  const auto s = parse_scenario(scenario(), "test.yaml", root_ / "scenarios");
  locd::sim::Simulation simulation(s, s.seed, 2.0);
  int64_t last = -1;
  int odometry = 0, scans = 0;
  while (auto m = simulation.next()) {
    const int64_t stamp = locd::header_of(m->measurement).stamp_ns;
    ASSERT_GE(stamp, last);
    EXPECT_EQ(stamp, simulation.stamp_of(m->t));
    last = stamp;
    odometry += std::holds_alternative<locd::Odometry>(m->measurement);
    scans += std::holds_alternative<locd::LaserScan>(m->measurement);
  }
  EXPECT_EQ(odometry, 101);
  EXPECT_EQ(scans, 51);
  const auto initial = simulation.initial_pose();
  EXPECT_NEAR(initial.pose.translation().x(), 3.1, 1e-12);
  EXPECT_NEAR(initial.covariance(0, 0), 0.25, 1e-12);
}

// A kidnap moves the truth (and so what the laser sees) but not the odometry.
TEST_F(ScenarioFiles, KidnapCarriesTheRobotUnseenByItsOdometry) {
  const auto s = parse_scenario(scenario("", "kidnap: {at_s: 2, min_distance_m: 10}\n"), "test.yaml", root_ / "scenarios");
  ASSERT_TRUE(s.kidnap);
  locd::sim::Simulation simulation(s, s.seed, 4.0);
  const auto event = simulation.event();
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, "kidnap");
  EXPECT_DOUBLE_EQ(event->t, 2.0);
  EXPECT_GE(event->distance_m, 10.0);
  // The truth jumps once, by the event's distance; the odometry steps stay about 2 cm (<= 1 m/s at 50 Hz).
  const auto& samples = simulation.truth().samples();
  int jumps = 0;
  for (size_t i = 1; i < samples.size(); ++i) {
    const double step = std::hypot(samples[i].pose.x - samples[i - 1].pose.x, samples[i].pose.y - samples[i - 1].pose.y);
    if (step > 1.0) {
      ++jumps;
      EXPECT_NEAR(samples[i].t, 2.0, 1e-9);
      EXPECT_NEAR(step, event->distance_m, 1e-9);
    }
  }
  EXPECT_EQ(jumps, 1);
  std::optional<locd::Pose2> last;
  double longest_step = 0.0;
  while (auto m = simulation.next()) {
    const auto* odometry = std::get_if<locd::Odometry>(&m->measurement);
    if (!odometry) continue;
    const auto pose = locd::Pose2::from_isometry(odometry->pose);
    if (last) longest_step = std::max(longest_step, std::hypot(pose.x - last->x, pose.y - last->y));
    last = pose;
  }
  EXPECT_GT(longest_step, 0.005);
  EXPECT_LT(longest_step, 0.05);
  // Another seed, another destination; the same seed, the same one.
  EXPECT_NE(locd::sim::Simulation(s, s.seed + 1, 4.0).event()->distance_m, event->distance_m);
  EXPECT_EQ(locd::sim::Simulation(s, s.seed, 4.0).event()->distance_m, event->distance_m);
}

TEST_F(ScenarioFiles, WrongStartGivesAPoseOnTheRouteFarOff) {
  std::string text = scenario();
  text.replace(text.find("initial_pose_offset: [0.1, 0, 0]"), 32, "wrong_start: {min_distance_m: 15}");
  const auto s = parse_scenario(text, "test.yaml", root_ / "scenarios");
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    locd::sim::Simulation simulation(s, seed, 1.0);
    const auto start = simulation.truth().at(0.0).pose;
    const auto given = locd::Pose2::from_isometry(simulation.initial_pose().pose);
    ASSERT_TRUE(simulation.event());
    EXPECT_EQ(simulation.event()->kind, "wrong_start");
    EXPECT_EQ(simulation.event()->t, 0.0);
    EXPECT_GE(std::hypot(given.x - start.x, given.y - start.y), 15.0);
    EXPECT_NEAR(given.y, 1.0, 1e-9);                              // on the route [[1, 1], [39, 1]]
    EXPECT_NEAR(std::sin(given.theta), 0.0, 1e-6);  // heading along it (the loop goes out and back)
    EXPECT_NEAR(simulation.initial_pose().covariance(0, 0), 0.25, 1e-12);  // the configured stddev
  }
}

TEST_F(ScenarioFiles, KidnapAndWrongStartErrorsNameTheKey) {
  EXPECT_NE(error_of(scenario("", "kidnap: {at_s: 9}\n")).find("'kidnap.at_s'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "kidnap: {min_distance_m: 9}\n")).find("'kidnap.at_s'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "kidnap: {at_s: 1, min_distance_m: 60}\n")).find("kidnap.min_distance_m"),
            std::string::npos);
  EXPECT_NE(error_of(scenario("", "kidnap: {at_s: 1, to: [1, 2]}\n")).find("'kidnap.to'"), std::string::npos);
  EXPECT_NE(error_of(scenario("", "kidnap: {at_s: 1, to: [1, 2, 0], min_distance_m: 3}\n")).find("exclude"),
            std::string::npos);
  std::string text = scenario();
  text.replace(text.find("initial_pose_offset: [0.1, 0, 0]"), 32, "wrong_start: {min_distance_m: 15}");
  EXPECT_EQ(error_of(text), "");
  EXPECT_NE(error_of(text + "  initial_pose_offset: [1, 0, 0]\n").find("exclude"), std::string::npos);
  const std::string both = scenario("", "kidnap: {at_s: 1}\n");
  text = both;
  text.replace(text.find("initial_pose_offset: [0.1, 0, 0]"), 32, "wrong_start: {min_distance_m: 15}");
  EXPECT_NE(error_of(text).find("exclude"), std::string::npos) << error_of(text);
}

TEST_F(ScenarioFiles, DifferencesChangeTheWorldNotTheMapAndTheirErrorsNameTheKey) {
  // A box across the corridor 2 m ahead of the robot: the world has it, the map does not.
  const std::string text = scenario("", "differences:\n  clutter: [{centre: [5.2, 1], size: [0.2, 1.8]}]\n");
  ASSERT_EQ(error_of(text), "");
  const auto s = parse_scenario(text, "test.yaml", root_ / "scenarios");
  EXPECT_NEAR(*s.world->cast({3.2, 1}, 0.0, 30.0), 1.9, 1e-9);
  EXPECT_EQ(s.map.lines.size(), locd::load_feature_map((root_ / "maps" / "corridor.yaml").string(), 100000).lines.size());
  const std::string door = error_of(scenario("", "differences:\n  doors: [{from: [1, 0], to: [2, 0], world: ajar}]\n"));
  EXPECT_NE(door.find("'differences.doors[0].world'"), std::string::npos) << door;
  EXPECT_NE(door.find("allowed"), std::string::npos) << door;
  const std::string laser = error_of(scenario("", "").replace(scenario("", "").find("laser: {rate_hz: 25}"), 20,
                                                             "laser: {rate_hz: 25, dropouts: {rate: 2}}"));
  EXPECT_NE(laser.find("'sensors.laser.dropouts.rate'"), std::string::npos) << laser;
}
