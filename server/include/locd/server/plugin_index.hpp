// The plugins a server offers, learnt without loading any plugin code into locd: each plugin file
// is opened by a short-lived, sandboxed `locd-worker --inspect FILE`, whose output (bounded in
// size and time) is parsed and checked here like any other text from outside. A plugin's static
// constructors therefore run only in inspector and worker processes, never in locd.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/plugin_set.hpp"
#include "locd/server/log.hpp"
#include "locd/server/worker_launch.hpp"

namespace locd::server {

// What a plugin's descriptor says, as its inspector reported it.
struct PluginDescription {
  std::string name;
  std::string version;
  std::string description;
  uint32_t consumes = 0;
  std::filesystem::path file;
};

// The inspector's output and its bounds.
constexpr size_t kMaxInspectionBytes = 4096;
constexpr size_t kMaxPluginVersionBytes = 64;
constexpr size_t kMaxPluginDescriptionBytes = 512;

// Parses what `locd-worker --inspect` printed for `file`:
//   locd-plugin-inspection 1
//   name NAME            ([a-z][a-z0-9_]{0,63})
//   version TEXT         (printable, at most kMaxPluginVersionBytes)
//   description TEXT     (printable, at most kMaxPluginDescriptionBytes)
//   consumes BITS        (a decimal within `supported_kinds`, not 0)
// each key once. Throws PluginLoadError naming the file and what is wrong.
PluginDescription parse_inspection(std::string_view output, const std::filesystem::path& file,
                                   uint32_t supported_kinds = kAllMeasurementKinds);

struct InspectorSettings {
  std::filesystem::path executable;  // locd-worker
  SandboxPaths sandbox;
  double timeout_s = 30.0;
  long memory_limit_mb = 4096;
};

// Runs the inspector on one file; its stderr goes to `logger` (escaped, rate-limited). Throws
// PluginLoadError naming the file and the cause (refused, crashed, timed out, bad output).
PluginDescription inspect_plugin(const std::filesystem::path& file, const InspectorSettings& settings, Logger& logger,
                                 uint32_t supported_kinds = kAllMeasurementKinds);

// Every plugin found in a list of directories, keyed by name. Files that fail inspection are
// recorded in rejected() ("file: cause") and never abort the scan; of two files naming the same
// plugin the first (in path order) wins.
class PluginIndex : public PluginSet<PluginDescription> {
 public:
  PluginIndex() = default;
  PluginIndex(const std::vector<std::filesystem::path>& directories, const InspectorSettings& settings, Logger& logger,
              uint32_t supported_kinds = kAllMeasurementKinds);
};

}  // namespace locd::server
