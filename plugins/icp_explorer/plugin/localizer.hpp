// The icp_explorer plugin: locd::Localizer around IcpExplorer. configure() reads every parameter
// (plugin/params.cpp; config/plugins/icp_explorer.yaml documents them) into IcpExplorerConfig; update()
// keeps the latest odometry and turns each cloud into a pose, diagnostics, the registered map
// (every publish_every_scans scans) and the exploration goal.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "locd/icp_explorer/icp_explorer.hpp"
#include "locd/icp_explorer/map_file.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::icp_explorer {

class IcpExplorerLocalizer : public Localizer {
 public:
  void configure(const PluginContext& context, const Params& params) override;
  void set_pose(const PoseEstimate& pose) override;
  UpdateResult update(const Measurement& measurement) override;
  std::string save_map() override;

 private:
  PluginContext context_;
  MapOutputSettings map_output_;
  std::unique_ptr<IcpExplorer> explorer_;
  size_t clouds_without_intensity_ = 0;
  size_t non_finite_points_ = 0;
};

}  // namespace locd::icp_explorer
