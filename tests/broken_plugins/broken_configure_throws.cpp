// Broken on purpose: configure() throws a std::runtime_error instead of a ConfigError.
#include <stdexcept>

#include "locd/sdk/plugin.hpp"

namespace {
class ThrowingConfigure : public locd::Localizer {
 public:
  void configure(const locd::PluginContext&, const locd::Params&) override {
    throw std::runtime_error("configure of broken_configure_throws failed on purpose");
  }
  void set_pose(const locd::PoseEstimate&) override {}
  locd::UpdateResult update(const locd::Measurement&) override { return {}; }
};
}  // namespace

LOCD_REGISTER_PLUGIN(ThrowingConfigure, "broken_configure_throws", "0.0.1", "fixture: configure throws",
                     locd::kinds(locd::MeasurementKind::kOdometry))
