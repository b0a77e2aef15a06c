// grid_mcl as the server loads it (liblocd_grid_mcl.so): the shipped configs, an AMCL YAML pasted
// as it is, every parameter error naming its key, map files refused with the file named, the map
// on the grid topic, global localization on request, and input it does not consume rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "error_of.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "test_env.hpp"

using namespace locd;
namespace fs = std::filesystem;

namespace {

std::shared_ptr<PluginLibrary> library() {
  static auto lib = PluginLibrary::open(fs::path(test::plugin_dir()) / "liblocd_grid_mcl.so");
  return lib;
}

struct GridMclPlugin : ::testing::Test {
  fs::path maps = fs::temp_directory_path() / ("grid_mcl_plugin_test_" + std::to_string(::getpid()));
  PluginContext context;
  std::vector<std::string> log;
  void SetUp() override {
    fs::create_directories(maps / "site");
    for (const char* f : {"corridor_grid.yaml", "corridor_grid.pgm"}) {
      fs::copy_file(fs::path(test::source_dir()) / "config/maps" / f, maps / f, fs::copy_options::overwrite_existing);
    }
    std::ofstream(maps / "site/small.pgm", std::ios::binary) << "P5\n4 3\n255\n" << std::string(12, '\xfe');
    std::ofstream(maps / "site/small.yaml") << "image: small.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
    std::ofstream(maps / "site/short.pgm", std::ios::binary) << "P5\n4 3\n255\n" << std::string(7, '\xfe');
    std::ofstream(maps / "site/short.yaml") << "image: short.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
    std::ofstream(maps / "site/outside.yaml") << "image: ../../outside.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
    std::ofstream(maps / "site/missing.yaml") << "image: nowhere.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
    std::ofstream(maps / "site/order.yaml")
        << "image: small.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.3\nfree_thresh: 0.4\n";
    context.robot_id = "r1";
    context.maps = MapResolver({maps});
    context.log = [this](LogLevel, const std::string& line) { log.push_back(line); };
  }
  void TearDown() override { fs::remove_all(maps); }

  LocalizerPtr configured(const std::string& text) {
    const PluginConfig pc = split_plugin_config(text, "test");
    LocalizerPtr l = library()->create();
    l->configure(context, pc.params);
    return l;
  }
  std::string error(const std::string& params) {
    return test::error_of([&] { configured("plugin: grid_mcl\nparams:\n" + params); });
  }
};

TEST_F(GridMclPlugin, ShippedConfigsConfigure) {
  for (const char* name : {"grid_mcl.yaml", "grid_mcl_warehouse.yaml"}) {
    PluginContext shipped = context;
    shipped.maps = MapResolver({fs::path(test::source_dir()) / "config/maps"});
    const PluginConfig pc = split_plugin_config(test::read_text(fs::path(test::source_dir()) / "config/plugins" / name), name);
    EXPECT_EQ(pc.plugin, "grid_mcl");
    LocalizerPtr l = library()->create();
    EXPECT_NO_THROW(l->configure(shipped, pc.params)) << name;
  }
}

TEST_F(GridMclPlugin, AnAmclYamlTranslatesOneToOne) {
  // Nav2's amcl parameters as they stand in nav2_params.yaml (ros__parameters), plus the map.
  const std::string amcl =
      "    map: corridor_grid.yaml\n    alpha1: 0.2\n    alpha2: 0.2\n    alpha3: 0.2\n    alpha4: 0.2\n    alpha5: 0.2\n"
      "    base_frame_id: base_footprint\n    beam_skip_distance: 0.5\n    beam_skip_error_threshold: 0.9\n"
      "    beam_skip_threshold: 0.3\n    do_beamskip: false\n    global_frame_id: map\n    lambda_short: 0.1\n"
      "    laser_likelihood_max_dist: 2.0\n    laser_max_range: 100.0\n    laser_min_range: -1.0\n"
      "    laser_model_type: likelihood_field\n    max_beams: 60\n    max_particles: 2000\n    min_particles: 500\n"
      "    odom_frame_id: odom\n    pf_err: 0.05\n    pf_z: 0.99\n    recovery_alpha_fast: 0.0\n    recovery_alpha_slow: 0.0\n"
      "    resample_interval: 1\n    robot_model_type: nav2_amcl::DifferentialMotionModel\n    save_pose_rate: 0.5\n"
      "    sigma_hit: 0.2\n    tf_broadcast: true\n    transform_tolerance: 1.0\n    update_min_a: 0.2\n    update_min_d: 0.25\n"
      "    z_hit: 0.5\n    z_max: 0.05\n    z_rand: 0.5\n    z_short: 0.05\n    scan_topic: scan\n"
      "    set_initial_pose: true\n    initial_pose: {x: 3.0, y: 1.0, z: 0.0, yaw: 0.0}\n";
  // The Nav2 params file: the ROS keys go to the robot's ros2 section, the rest configures the plugin.
  const PluginConfig nav2 = split_plugin_config("amcl:\n  ros__parameters:\n" + amcl, "nav2_params.yaml");
  ASSERT_EQ(nav2.plugin, "grid_mcl");
  EXPECT_EQ(nav2.ros2->base_frame, "base_footprint");
  LocalizerPtr l = library()->create();
  EXPECT_NO_THROW(l->configure(context, nav2.params));
  std::string beamskip = amcl;
  beamskip.replace(beamskip.find("do_beamskip: false"), 18, "do_beamskip: true");
  const PluginConfig skipping = split_plugin_config("amcl:\n  ros__parameters:\n" + beamskip, "nav2_params.yaml");
  const std::string refused = test::error_of([&] { library()->create()->configure(context, skipping.params); });
  EXPECT_NE(refused.find("'amcl.ros__parameters.do_beamskip' (line 13, column 18) = true is not supported"),
            std::string::npos) << refused;
  // In grid_mcl's own params a ROS key is refused by name, saying where it is honoured.
  const std::string ros_key = error("  map: corridor_grid.yaml\n  tf_broadcast: true\n");
  EXPECT_NE(ros_key.find("'grid_mcl.tf_broadcast' (line 4"), std::string::npos) << ros_key;
  EXPECT_NE(ros_key.find("is a ROS 2 setting, not grid_mcl's"), std::string::npos) << ros_key;
}

TEST_F(GridMclPlugin, ParameterErrorsNameTheirKey) {
  const std::string map = "  map: corridor_grid.yaml\n";
  EXPECT_NE(error("  alpha1: 0.1\n").find(".map'"), std::string::npos) << error("  alpha1: 0.1\n");
  EXPECT_NE(error(map + "  laser_model_type: sonar\n").find(".laser_model_type'"), std::string::npos);
  EXPECT_NE(error(map + "  z_hit: 1.5\n").find(".z_hit'"), std::string::npos);
  EXPECT_NE(error(map + "  unknown_occupancy: 1.5\n").find(".unknown_occupancy'"), std::string::npos)
      << error(map + "  unknown_occupancy: 1.5\n");
  EXPECT_NE(error(map + "  min_particles: 5000\n  max_particles: 100\n").find(".max_particles'"), std::string::npos);
  EXPECT_NE(error(map + "  max_particles: 200000\n").find("100000"), std::string::npos)
      << "bounded by the server's limits.max_particles: " << error(map + "  max_particles: 200000\n");
  EXPECT_NE(error(map + "  recovery_alpha_slow: 0.2\n  recovery_alpha_fast: 0.1\n").find(".recovery_alpha_fast'"),
            std::string::npos);
  EXPECT_NE(error(map + "  robot_model_type: tank\n").find(".robot_model_type'"), std::string::npos);
  EXPECT_NE(error(map + "  set_initial_pose: true\n").find("initial_pose"), std::string::npos);
  EXPECT_NE(error(map + "  sigma_hits: 0.1\n").find("unknown parameter 'grid_mcl.sigma_hits'"), std::string::npos);
  EXPECT_NE(error(map + "  localization_state: {lost_max_fit: 0.9}\n").find(".localization_state.lost_max_fit'"),
            std::string::npos);
}

TEST_F(GridMclPlugin, MapFilesAreRefusedWithTheFileNamed) {
  const auto map_error = [&](const std::string& map) { return error("  map: " + map + "\n"); };
  EXPECT_NE(map_error("site/short.yaml").find("'short.pgm': has 7 bytes of pixel data"), std::string::npos)
      << map_error("site/short.yaml");
  EXPECT_NE(map_error("site/missing.yaml").find("map 'missing.yaml': parameter 'image'"), std::string::npos)
      << map_error("site/missing.yaml");
  EXPECT_NE(map_error("site/outside.yaml").find("parameter 'image'"), std::string::npos) << map_error("site/outside.yaml");
  EXPECT_NE(map_error("site/order.yaml").find("'free_thresh'"), std::string::npos) << map_error("site/order.yaml");
  EXPECT_NE(map_error("/etc/hosts").find(".map'"), std::string::npos) << map_error("/etc/hosts");
  EXPECT_NE(map_error("../etc.yaml").find(".map'"), std::string::npos);
  // A map bigger than limits.max_map_cells is refused before its pixels are read.
  context.limits.max_map_cells = 10;
  EXPECT_NE(map_error("site/small.yaml").find("more than limits.max_map_cells = 10"), std::string::npos)
      << map_error("site/small.yaml");
  // A map without any free cell cannot be localized in.
  context.limits = Limits{};
  std::ofstream(maps / "site/small.pgm", std::ios::binary) << "P5\n4 3\n255\n" << std::string(12, '\0');
  EXPECT_NE(map_error("site/small.yaml").find("no free cell"), std::string::npos) << map_error("site/small.yaml");
}

TEST_F(GridMclPlugin, TheMapGoesOutAsAGrid) {
  LocalizerPtr a = configured("plugin: grid_mcl\nparams:\n  map: corridor_grid.yaml\n");
  const UpdateResult out = a->initial_outputs();
  ASSERT_TRUE(out.grid);
  EXPECT_EQ(out.grid->layer, "occupancy");
  EXPECT_EQ(out.grid->width * out.grid->height, static_cast<int>(out.grid->cells.size()));
  EXPECT_DOUBLE_EQ(out.grid->resolution, 0.05);
  size_t occupied = 0, unknown = 0;
  for (float c : out.grid->cells) {
    occupied += c == 1.0f;
    unknown += std::isnan(c);
  }
  EXPECT_GT(occupied, 1000u);
  EXPECT_GT(unknown, 1000u);
  EXPECT_FALSE(configured("plugin: grid_mcl\nparams:\n  map: corridor_grid.yaml\n  publish_map: false\n")
                   ->initial_outputs()
                   .grid);
}

TEST_F(GridMclPlugin, GlobalLocalizationOnRequestAndForeignInputRejected) {
  LocalizerPtr l = configured(
      "plugin: grid_mcl\nparams:\n  map: corridor_grid.yaml\n  set_initial_pose: true\n"
      "  initial_pose: {x: 3.0, y: 1.0, yaw: 0.0}\n  max_particles: 3000\n  global_particles: 3000\n");
  LaserScan scan;
  scan.header.stamp_ns = 10;
  scan.angle_min = -1.0f;
  scan.angle_increment = 0.1f;
  scan.range_min = 0.1f;
  scan.range_max = 10.0f;
  scan.ranges.assign(21, 1.0f);
  const UpdateResult tracked = l->update(scan);
  ASSERT_TRUE(tracked.estimate);
  EXPECT_NEAR(tracked.estimate->pose.translation().x(), 3.0, 1.0);
  ASSERT_TRUE(tracked.localization);
  // A client's pose whose position stddev reaches global_localization_stddev (1000 m): global.
  PoseEstimate anywhere;
  anywhere.covariance = Matrix6d::Identity() * 1e7;
  l->set_pose(anywhere);
  scan.header.stamp_ns = 20;
  const UpdateResult global = l->update(scan);
  ASSERT_TRUE(global.localization);
  EXPECT_EQ(global.localization->state, LocalizationState::kLost) << global.localization->reason;
  EXPECT_EQ(global.diagnostics.values[0].first, "particles");
  EXPECT_EQ(global.diagnostics.values[0].second, 3000.0);
  // Input it does not consume, and a pose that is not finite.
  Image image;
  EXPECT_THROW(l->update(image), InputError);
  PoseEstimate broken;
  broken.pose.translation().x() = std::nan("");
  EXPECT_THROW(l->set_pose(broken), InputError);
}

}  // namespace
