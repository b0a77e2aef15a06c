// Broken on purpose: the constructor (run by the factory) throws.
#include <stdexcept>

#include "locd/sdk/plugin.hpp"

namespace {
class ThrowingConstructor : public locd::Localizer {
 public:
  ThrowingConstructor() { throw std::runtime_error("constructor of broken_factory_throws failed on purpose"); }
  void configure(const locd::PluginContext&, const locd::Params&) override {}
  void set_pose(const locd::PoseEstimate&) override {}
  locd::UpdateResult update(const locd::Measurement&) override { return {}; }
};
}  // namespace

LOCD_REGISTER_PLUGIN(ThrowingConstructor, "broken_factory_throws", "0.0.1", "fixture: factory throws",
                     locd::kinds(locd::MeasurementKind::kOdometry))
