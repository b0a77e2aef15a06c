// Broken on purpose: consumes measurement kind bit 1u << 10, which no server can give.
#include "locd/sdk/plugin.hpp"

namespace {
class NeedsUnknownInput : public locd::Localizer {
 public:
  void configure(const locd::PluginContext&, const locd::Params&) override {}
  void set_pose(const locd::PoseEstimate&) override {}
  locd::UpdateResult update(const locd::Measurement&) override { return {}; }
};
}  // namespace

LOCD_REGISTER_PLUGIN(NeedsUnknownInput, "broken_needs_input", "0.0.1", "fixture: needs an input kind 1<<10",
                     locd::kinds(locd::MeasurementKind::kOdometry) | (1u << 10))
