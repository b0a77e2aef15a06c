// The image pipeline on rendered frames of the scenario's hall at its configured noise: Hough
// recall >= 0.95, few false circles, centres within a pixel, and the detected ceiling points
// where the landmarks really are (eq. 1-3 end to end).
#include <gtest/gtest.h>

#include <random>

#include "locd/ceiling_pf/ceiling_camera.hpp"
#include "locd/ceiling_pf/ceiling_detector.hpp"
#include "locd/sim_ceiling_pf/ceiling_world.hpp"
#include "test_env.hpp"

using namespace locd;
using namespace locd::ceiling_pf;
namespace simc = locd::sim::ceiling;

namespace {
struct ScenarioCamera {
  simc::CeilingCameraConfig camera;
  simc::CeilingWorldConfig world;
};
ScenarioCamera scenario_camera() {
  const Params scenario = Params::load_file(test::source_dir() + "/config/scenarios/ceiling_hall.yaml");
  const Params cam = scenario.child("sensors").child("ceiling_camera");
  return {simc::CeilingCameraConfig::from_params(cam), simc::CeilingWorldConfig::from_params(cam.child("world"))};
}
}  // namespace

struct RecallCase {
  const char* name;
  double noise_stddev;
  double min_recall;
};

class CeilingPfDetectorRecall : public ::testing::TestWithParam<RecallCase> {};

TEST_P(CeilingPfDetectorRecall, HoughFindsTheLandmarksInRenderedFrames) {
  ScenarioCamera sc = scenario_camera();
  if (GetParam().noise_stddev >= 0.0) sc.camera.noise_stddev = GetParam().noise_stddev;
  const simc::CeilingWorld world(sc.world);
  const simc::CeilingCameraRenderer renderer(sc.camera, world);
  const CeilingCamera camera(CameraIntrinsics{sc.camera.width, sc.camera.height, sc.camera.fx, sc.camera.fy,
                                              sc.camera.cx, sc.camera.cy},
                             CameraMounting{sc.camera.mount.x, sc.camera.mount.y, sc.camera.mount.theta,
                                            sc.camera.lens_height},
                             sc.world.ceiling_height);
  CeilingDetector detector{DetectorConfig{}};
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> x(2, sc.world.size.x() - 2), y(2, sc.world.size.y() - 2), yaw(-M_PI, M_PI);
  int visible = 0, found = 0, circles = 0, false_circles = 0;
  double error2 = 0.0, point_error2 = 0.0;
  for (int frame = 0; frame < 120; ++frame) {
    const Pose2 robot(x(rng), y(rng), yaw(rng));
    const cv::Mat image = renderer.render(robot, rng);
    const std::vector<CircleDetection> detected = detector.detect(image);
    const auto truth = renderer.visible(robot);
    visible += static_cast<int>(truth.size());
    circles += static_cast<int>(detected.size());
    for (const auto& v : truth) {
      for (const CircleDetection& c : detected) {
        const double d = std::hypot(c.column - v.pixel.x(), c.row - v.pixel.y());
        if (d < 3.0) {
          ++found;
          error2 += d * d;
          point_error2 += (camera.ceiling_point_in_base(c.column, c.row) - v.in_base).squaredNorm();
          break;
        }
      }
    }
    for (const CircleDetection& c : detected) {
      bool landmark = false;
      for (const Eigen::Vector2d& l : world.landmarks())
        landmark = landmark || (renderer.project(robot, l) - Eigen::Vector2d(c.column, c.row)).norm() < 3.0;
      false_circles += !landmark;
    }
  }
  ASSERT_GT(visible, 60);
  const double recall = static_cast<double>(found) / visible;
  RecordProperty("recall", std::to_string(recall));
  EXPECT_GE(recall, GetParam().min_recall) << GetParam().name << ": " << found << " of " << visible;
  EXPECT_LT(static_cast<double>(false_circles), 0.1 * circles + 1);
  EXPECT_LT(std::sqrt(error2 / found), 0.5) << "centre error, pixels";
  EXPECT_LT(std::sqrt(point_error2 / found), 0.01) << "ceiling point error, metres";
}

INSTANTIATE_TEST_SUITE_P(Noise, CeilingPfDetectorRecall,
                         ::testing::Values(RecallCase{"configured", -1.0, 0.95}, RecallCase{"noisier", 12.0, 0.95}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(CeilingPfDetector, EmptyCeilingGivesNoCircles) {
  cv::Mat flat(480, 640, CV_8UC1, cv::Scalar(90));
  cv::randn(flat, 90, 6);
  CeilingDetector detector{DetectorConfig{}};
  EXPECT_TRUE(detector.detect(flat).empty());
}
