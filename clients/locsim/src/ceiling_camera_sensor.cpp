#include "locd/sim/ceiling_camera_sensor.hpp"

#include "locd/sim_ceiling_pf/ceiling_world.hpp"

namespace locd::sim {
namespace {

using ceiling::CeilingCameraConfig;
using ceiling::CeilingCameraRenderer;
using ceiling::CeilingWorld;
using ceiling::CeilingWorldConfig;

class CeilingCameraSensor : public SensorModel {
 public:
  explicit CeilingCameraSensor(const Params& params)
      : world_(CeilingWorldConfig::from_params(params.child("world"))),
        renderer_(CeilingCameraConfig::from_params(params), world_) {}
  const std::string& name() const override { return name_; }
  double rate_hz() const override { return renderer_.config().rate_hz; }
  Measurement measure(const TruthSample& truth, int64_t stamp_ns, std::mt19937_64& rng) override {
    return renderer_.image(truth.pose, stamp_ns, rng);
  }

 private:
  std::string name_ = "ceiling_camera";
  CeilingWorld world_;
  CeilingCameraRenderer renderer_;
};

}  // namespace

std::unique_ptr<SensorModel> make_ceiling_camera_sensor(const Params& params) {
  return std::make_unique<CeilingCameraSensor>(params);
}

}  // namespace locd::sim
