// Broken on purpose: built against a future plugin ABI (version 999).
#include "locd/sdk/plugin.hpp"

extern "C" __attribute__((visibility("default"))) const locd_plugin_descriptor_t* locd_plugin_descriptor() {
  static const locd_plugin_descriptor_t descriptor{
      999u, "broken_abi_version", "0.0.1", "fixture: wrong ABI version",
      static_cast<uint32_t>(locd::MeasurementKind::kOdometry), nullptr, nullptr};
  return &descriptor;
}
