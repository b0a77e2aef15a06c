// The simulated ceiling hall of the ceiling_pf paper: identical round landmarks at one ceiling
// height (grid, jittered grid or random layout), a few distractor blobs, a lighting gradient,
// and an upward camera that renders real 8-bit mono images of it. Everything is deterministic
// from the seeds given. No DDS here.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"

namespace locd::sim::ceiling {

struct CeilingWorldConfig {
  std::string layout = "jittered_grid";  // grid | jittered_grid | random
  Eigen::Vector2d size{100.0, 50.0};     // m, hall from (0, 0)
  int columns = 27;                      // grid layouts: columns x rows cells, one landmark each
  int rows = 11;
  int count = 297;                       // random layout (grid layouts: columns * rows)
  double jitter = 0.8;                   // m, jittered grid: uniform offset in [-jitter, jitter]
  double min_separation = 1.0;           // m, random layout
  double ceiling_height = 2.42;          // m
  double landmark_radius = 0.15;         // m
  int distractors = 60;                  // bright non-round blobs (tubes, vents)
  double background = 95.0;              // grey level at the hall's centre
  double lighting_gradient = 1.2;        // grey levels per metre along x
  double landmark_intensity = 235.0;
  uint64_t seed = 5;

  static CeilingWorldConfig from_params(const Params& params);
};

struct Distractor {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double length = 1.0, width = 0.1, angle = 0.0;  // m, m, rad: a bright bar (tube, vent)
  double intensity = 220.0;
};

class CeilingWorld {
 public:
  explicit CeilingWorld(const CeilingWorldConfig& config);
  const CeilingWorldConfig& config() const { return config_; }
  const std::vector<Eigen::Vector2d>& landmarks() const { return landmarks_; }
  const std::vector<Distractor>& distractors() const { return distractors_; }
  double background_at(const Eigen::Vector2d& ceiling_point) const;
  // The landmark map file ceiling_pf reads (frame_id, ceiling_height, landmarks).
  std::string map_yaml() const;

 private:
  CeilingWorldConfig config_;
  std::vector<Eigen::Vector2d> landmarks_;
  std::vector<Distractor> distractors_;
};

struct CeilingCameraConfig {
  double rate_hz = 10.0;
  int width = 640, height = 480;
  double fx = 240.0, fy = 240.0, cx = 319.5, cy = 239.5;
  Pose2 mount;                // camera in base_link; image top edge along mount yaw
  double lens_height = 0.32;  // m above the floor
  double blur_sigma = 1.0;    // px, optics
  double noise_stddev = 6.0;  // grey levels, per pixel
  std::string frame_id = "ceiling_camera";

  static CeilingCameraConfig from_params(const Params& params);
};

struct VisibleLandmark {
  int index = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // column, row
  double radius_px = 0.0;
  Eigen::Vector2d in_base = Eigen::Vector2d::Zero();
};

class CeilingCameraRenderer {
 public:
  CeilingCameraRenderer(const CeilingCameraConfig& config, const CeilingWorld& world);

  // Where a ceiling point (map frame) appears from a robot pose (column, row).
  Eigen::Vector2d project(const Pose2& robot, const Eigen::Vector2d& ceiling_point) const;
  // Landmarks whose whole disk lies inside the image.
  std::vector<VisibleLandmark> visible(const Pose2& robot) const;
  // The 8-bit mono frame: lighting gradient, landmarks, distractors, optical blur, pixel noise.
  cv::Mat render(const Pose2& robot, std::mt19937_64& rng) const;
  Image image(const Pose2& robot, int64_t stamp_ns, std::mt19937_64& rng) const;
  double pixels_per_metre() const { return config_.fx / (world_.config().ceiling_height - config_.lens_height); }
  const CeilingCameraConfig& config() const { return config_; }

 private:
  CeilingCameraConfig config_;
  const CeilingWorld& world_;
  cv::Mat_<float> noise_tile_;  // pixel noise, twice the image size; each frame takes a random window
};

}  // namespace locd::sim::ceiling
