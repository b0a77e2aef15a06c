// Broken on purpose: a plugin name that could be a path ("../Evil.so" is not [a-z][a-z0-9_]*).
#include "locd/sdk/plugin.hpp"

namespace {
class NamelessLocalizer : public locd::Localizer {
 public:
  void configure(const locd::PluginContext&, const locd::Params&) override {}
  void set_pose(const locd::PoseEstimate&) override {}
  locd::UpdateResult update(const locd::Measurement&) override { return {}; }
};
}  // namespace

LOCD_REGISTER_PLUGIN(NamelessLocalizer, "../Evil.so", "0.0.1", "fixture: invalid name",
                     locd::kinds(locd::MeasurementKind::kOdometry))
