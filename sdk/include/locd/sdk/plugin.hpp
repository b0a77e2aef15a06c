// The plugin contract. A localizer plugin is one shared object exporting one C entry point,
// `locd_plugin_descriptor`, that returns a descriptor: ABI version, name, version, consumed
// measurement kinds and a factory. The server checks the ABI version before anything else.
//
//   class MyLocalizer : public locd::Localizer { ... };
//   LOCD_REGISTER_PLUGIN(MyLocalizer, "my_localizer", "1.0.0", "what it does",
//                        locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"

#define LOCD_PLUGIN_ABI_VERSION 1u
#define LOCD_PLUGIN_ENTRY_POINT "locd_plugin_descriptor"

namespace locd {

// Upper bounds on what a plugin may allocate from network data or configs. The server fills
// these from its own config; the bridge enforces the sensor ones before converting a sample.
struct Limits {
  size_t max_scan_beams = 8192;
  size_t max_cloud_points = 1'000'000;
  size_t max_image_pixels = 4'000'000;
  size_t max_detections = 1024;
  size_t max_particles = 100'000;
  size_t max_map_cells = 50'000'000;
};

// Resolves a map file name from a config against the configured map directories. Only
// relative names without "..", and only files that really lie inside a map directory (after
// following links), are accepted: a remote request can never name an arbitrary path.
class MapResolver {
 public:
  MapResolver() = default;
  explicit MapResolver(std::vector<std::filesystem::path> directories);
  std::filesystem::path resolve(const std::string& name) const;  // throws ConfigError
  const std::vector<std::filesystem::path>& directories() const { return directories_; }

 private:
  std::vector<std::filesystem::path> directories_;
};

enum class LogLevel { kDebug, kInfo, kWarning, kError };

struct PluginContext {
  std::string robot_id;
  Limits limits;
  MapResolver maps;
  // Where the plugin may write files (saved maps), from the server's own config
  // (`output_directory`); empty = writing disabled. Never taken from a remote request.
  std::filesystem::path output_directory;
  std::function<void(LogLevel, const std::string&)> log = [](LogLevel, const std::string&) {};
};

// One localizer instance serves one robot. Calls are serial: never two at once.
class Localizer {
 public:
  virtual ~Localizer() = default;

  // Validate everything up front; throw ConfigError naming the key, value and what is allowed.
  virtual void configure(const PluginContext& context, const Params& params) = 0;

  // Initial pose (from a client, or from the plugin this one replaces).
  virtual void set_pose(const PoseEstimate& pose) = 0;

  // One measurement, in stamp order. Throw InputError to reject it; the session goes on.
  virtual UpdateResult update(const Measurement& measurement) = 0;

  // Outputs to publish once after configure (maps: transient-local), e.g. the landmark map.
  virtual UpdateResult initial_outputs() const { return {}; }

  // Saves the plugin's map on request into the directory named by the plugin's own config, under
  // a file name the plugin generates (never a path from a request); returns the file written.
  // Plugins that keep no map leave this default, which rejects the request.
  virtual std::string save_map() { throw InputError("this plugin keeps no map to save"); }
};

constexpr uint32_t kinds() { return 0; }
template <typename... Rest>
constexpr uint32_t kinds(MeasurementKind first, Rest... rest) {
  return static_cast<uint32_t>(first) | kinds(rest...);
}

}  // namespace locd

extern "C" {
struct locd_plugin_descriptor_t {
  uint32_t abi_version;          // LOCD_PLUGIN_ABI_VERSION
  const char* name;              // [a-z][a-z0-9_]*, what a session request names
  const char* version;
  const char* description;
  uint32_t consumes;             // bits of locd::MeasurementKind
  locd::Localizer* (*create)();  // new instance; may throw
  void (*destroy)(locd::Localizer*);
};
}

#define LOCD_REGISTER_PLUGIN(CLASS, NAME, VERSION, DESCRIPTION, CONSUMES)                  \
  extern "C" __attribute__((visibility("default"))) const locd_plugin_descriptor_t*      \
  locd_plugin_descriptor() {                                                              \
    static const locd_plugin_descriptor_t descriptor{                                     \
        LOCD_PLUGIN_ABI_VERSION, NAME, VERSION, DESCRIPTION, CONSUMES,                    \
        []() -> locd::Localizer* { return new CLASS(); },                                \
        [](locd::Localizer* instance) { delete instance; }};                              \
    return &descriptor;                                                                   \
  }
