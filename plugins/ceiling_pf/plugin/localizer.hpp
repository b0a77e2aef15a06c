// ceiling_pf's Localizer: thin I/O around the core. Odometry predicts, a mono image goes through
// the detector, on-board detections go straight to the filter; every correction returns the
// pose, the filter's diagnostics, the association of the best particle, a subsample of the
// particles and the localization state.
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "locd/ceiling_pf/ceiling_camera.hpp"
#include "locd/ceiling_pf/ceiling_detector.hpp"
#include "locd/ceiling_pf/ceiling_particle_filter.hpp"
#include "locd/ceiling_pf/landmark_map.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::ceiling_pf {

class CeilingPfLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  UpdateResult initial_outputs() const override;

 private:
  UpdateResult on_odometry(const Odometry& odometry);
  UpdateResult on_image(const Image& image);
  UpdateResult on_detections(const LandmarkDetections& frame);
  UpdateResult correct(const Header& header, const std::vector<Detection>& detections);
  // The localization state after a correction (criteria in localizer.cpp and the README).
  LocalizationAssessment assess(const CorrectionReport& report, size_t weighted_particles);
  std::optional<PoseEstimate> make_estimate(const Header& header) const;

  Config config_;
  LandmarkMap map_;
  std::unique_ptr<CeilingCamera> camera_;
  std::unique_ptr<CeilingDetector> detector_;
  std::unique_ptr<CeilingParticleFilter> filter_;
  std::optional<Pose2> last_odometry_;
  int64_t last_odometry_stamp_ = 0;
  size_t rejected_ = 0;
  std::deque<double> explained_;  // share of detections explained, the last frames with detections
};

}  // namespace locd::ceiling_pf
