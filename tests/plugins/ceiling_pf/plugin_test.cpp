// The plugin as the server loads it: the shipped config, every parameter error naming its key,
// bad input rejected with the session going on, and a short drive through rendered images.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sim_ceiling_pf/hall_drive.hpp"
#include "test_env.hpp"

using namespace locd;
namespace fs = std::filesystem;
namespace simc = locd::sim::ceiling;

namespace {

std::shared_ptr<PluginLibrary> library() {
  static auto lib = PluginLibrary::open(fs::path(test::plugin_dir()) / "liblocd_ceiling_pf.so");
  return lib;
}

struct Fixture {
  fs::path maps = fs::temp_directory_path() / ("ceiling_pf_plugin_test_" + std::to_string(::getpid()));
  PluginContext context;
  Fixture() {
    fs::create_directories(maps);
    fs::copy_file(fs::path(test::source_dir()) / "config/maps/ceiling_hall.yaml", maps / "ceiling_hall.yaml",
                  fs::copy_options::overwrite_existing);
    std::ofstream(maps / "empty.yaml") << "ceiling_height: 2.42\nlandmarks: []\n";
    std::ofstream(maps / "broken.yaml") << "ceiling_height: 2.42\nlandmarks: [[1, 2], [3]]\n";
    context.robot_id = "r1";
    context.maps = MapResolver({maps});
  }
  ~Fixture() { fs::remove_all(maps); }
  std::string shipped() const { return test::read_text(fs::path(test::source_dir()) / "config/plugins/ceiling_pf.yaml"); }
  LocalizerPtr configured(const std::string& text) const {
    const PluginConfig pc = split_plugin_config(text, "test");
    LocalizerPtr l = library()->create();
    l->configure(context, pc.params);
    return l;
  }
  std::string config_error(const std::string& text) const {
    try {
      configured(text);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  }
};

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace

TEST(CeilingPfPlugin, DescriptorAndShippedConfig) {
  EXPECT_EQ(library()->name(), "ceiling_pf");
  const uint32_t consumes = library()->descriptor().consumes;
  EXPECT_TRUE(consumes & static_cast<uint32_t>(MeasurementKind::kImage));
  EXPECT_TRUE(consumes & static_cast<uint32_t>(MeasurementKind::kLandmarkDetections));
  EXPECT_TRUE(consumes & static_cast<uint32_t>(MeasurementKind::kOdometry));
  Fixture f;
  LocalizerPtr l = f.configured(f.shipped());
  const UpdateResult outputs = l->initial_outputs();
  ASSERT_TRUE(outputs.landmark_map.has_value());
  EXPECT_EQ(outputs.landmark_map->size(), 297u);
  EXPECT_NEAR(outputs.landmark_map->front().a.z(), 2.42, 1e-9);
}

TEST(CeilingPfPlugin, ParameterErrorsNameKeyValueAndAllowed) {
  Fixture f;
  const std::string good = f.shipped();
  std::string e = f.config_error(replace(good, "fx: 240", "fx: -240"));
  EXPECT_NE(e.find("ceiling_pf.camera.fx"), std::string::npos) << e;
  EXPECT_NE(e.find("-240"), std::string::npos) << e;
  e = f.config_error(replace(good, "blur_kernel: 5", "blur_kernel: 4"));
  EXPECT_NE(e.find("ceiling_pf.detector.blur_kernel"), std::string::npos) << e;
  EXPECT_NE(e.find("odd"), std::string::npos) << e;
  e = f.config_error(replace(good, "alpha_fast: 0.1", "alpha_fast: 0.0001"));
  EXPECT_NE(e.find("alpha_fast"), std::string::npos) << e;
  e = f.config_error(replace(good, "hit_fraction: 0.95", "hit_fraction: 1.5"));
  EXPECT_NE(e.find("ceiling_pf.measurement.hit_fraction"), std::string::npos) << e;
  EXPECT_NE(e.find("(0, 1]"), std::string::npos) << e;
  e = f.config_error(replace(good, "alpha: [0.3, 0.3, 0.1, 0.25, 0.001, 0.001]", "alpha: [0.3, 0.3]"));
  EXPECT_NE(e.find("ceiling_pf.motion.alpha"), std::string::npos) << e;
  e = f.config_error(replace(good, "  camera:", "  camera_typo: {}\n  camera:"));
  EXPECT_NE(e.find("camera_typo"), std::string::npos) << e;
  e = f.config_error(replace(replace(good, "    width: 640\n", ""), "fx: 240", "fx_missing: 1"));
  EXPECT_NE(e.find("fx"), std::string::npos) << e;
  e = f.config_error("plugin: ceiling_pf\nparams:\n  map: ceiling_hall.yaml\n");
  EXPECT_NE(e.find("ceiling_pf.camera"), std::string::npos) << e;
  e = f.config_error(replace(good, "map: ceiling_hall.yaml", "map: ../ceiling_hall.yaml"));
  EXPECT_NE(e.find(".."), std::string::npos) << e;
  e = f.config_error(replace(good, "map: ceiling_hall.yaml", "map: empty.yaml"));
  EXPECT_NE(e.find("landmarks"), std::string::npos) << e;
  e = f.config_error(replace(good, "map: ceiling_hall.yaml", "map: broken.yaml"));
  EXPECT_NE(e.find("landmarks[1]"), std::string::npos) << e;
  f.context.limits.max_image_pixels = 1000;
  e = f.config_error(good);
  EXPECT_NE(e.find("max_image_pixels"), std::string::npos) << e;
}

TEST(CeilingPfPlugin, BadInputIsRejectedAndTheSessionGoesOn) {
  Fixture f;
  LocalizerPtr l = f.configured(replace(f.shipped(), "# initial_pose: [30.38, 27.2, 0.0]", "initial_pose: [30.38, 27.2, 0.0]"));
  auto input_error = [&](const Measurement& m) {
    try {
      l->update(m);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  Image bgr;
  bgr.width = 640;
  bgr.height = 480;
  bgr.channels = 3;
  bgr.data.assign(640 * 480 * 3, 0);
  EXPECT_NE(input_error(bgr).find("mono8"), std::string::npos);
  Image small;
  small.width = 320;
  small.height = 240;
  small.data.assign(320 * 240, 0);
  EXPECT_NE(input_error(small).find("640 x 480"), std::string::npos);
  // Truncated images, NaN detections, oversized frames and stamps going backwards never reach the
  // plugin: the bridge and the session refuse them (tests/sdk/validate_test.cpp, tests/sdk/
  // convert_test.cpp, tests/server/session_test.cpp).
  Odometry o;
  o.header.stamp_ns = 2'000'000'000;
  EXPECT_EQ(input_error(o), "accepted");
  EXPECT_NE(input_error(PointCloud{}).find("consumes"), std::string::npos);
  // Still working: a good (empty) frame gives an estimate and counts the rejections.
  Image dark;
  dark.width = 640;
  dark.height = 480;
  dark.data.assign(640 * 480, 80);
  const UpdateResult r = l->update(dark);
  ASSERT_TRUE(r.estimate.has_value());
  bool counted = false;
  for (const auto& [name, value] : r.diagnostics.values) counted = counted || (name == "rejected_inputs" && value == 3.0);
  EXPECT_TRUE(counted);
}

TEST(CeilingPfPlugin, TracksThroughRenderedImages) {
  Fixture f;
  LocalizerPtr l = f.configured(f.shipped());
  const Params scenario = Params::load_file(test::source_dir() + "/config/scenarios/ceiling_hall.yaml");
  const Params cam = scenario.child("sensors").child("ceiling_camera");
  const simc::CeilingWorld world(simc::CeilingWorldConfig::from_params(cam.child("world")));
  const simc::CeilingCameraRenderer renderer(simc::CeilingCameraConfig::from_params(cam), world);
  simc::HallDrive drive(simc::DriveConfig{}, renderer, 4);
  PoseEstimate start;
  start.pose = drive.truth().pose.to_isometry();
  start.covariance = Matrix6d::Identity() * 0.01;
  l->set_pose(start);
  double last_error = 1e9;
  size_t frames_with_particles = 0;
  while (auto event = drive.next(30.0)) {
    const UpdateResult r = l->update(event->measurement);
    ASSERT_TRUE(r.estimate.has_value());
    const Pose2 e = Pose2::from_isometry(r.estimate->pose);
    last_error = std::hypot(e.x - event->truth.x, e.y - event->truth.y);
    if (!r.diagnostics.particles.empty()) {
      ++frames_with_particles;
      EXPECT_LE(r.diagnostics.particles.size(), 500u);
    }
  }
  EXPECT_GT(frames_with_particles, 250u);
  EXPECT_LT(last_error, 0.1);
}
