// Loading plugins from shared objects. Used by the server and by `locsim run` (offline), so both
// run exactly the same plugin code. A plugin is found by the name in its descriptor, only in the
// configured directories.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/plugin_set.hpp"

namespace locd {

class PluginLibrary;

// Owns a Localizer and keeps its library loaded for as long as the instance lives.
struct LocalizerDeleter {
  std::shared_ptr<const PluginLibrary> library;
  void operator()(Localizer* instance) const;
};
using LocalizerPtr = std::unique_ptr<Localizer, LocalizerDeleter>;

class PluginLibrary : public std::enable_shared_from_this<PluginLibrary> {
 public:
  // Opens and checks a library: entry point present, ABI version, a valid name, consumed kinds
  // within `supported_kinds`. Throws PluginLoadError naming the file and the cause.
  static std::shared_ptr<PluginLibrary> open(const std::filesystem::path& file,
                                             uint32_t supported_kinds = kAllMeasurementKinds);
  ~PluginLibrary();
  PluginLibrary(const PluginLibrary&) = delete;
  PluginLibrary& operator=(const PluginLibrary&) = delete;

  const locd_plugin_descriptor_t& descriptor() const { return *descriptor_; }
  std::string name() const { return descriptor_->name; }
  const std::filesystem::path& file() const { return file_; }

  // A new instance. A factory that throws or returns null becomes a PluginLoadError.
  LocalizerPtr create() const;

 private:
  PluginLibrary(void* handle, std::filesystem::path file, const locd_plugin_descriptor_t* d);
  void* handle_;
  std::filesystem::path file_;
  const locd_plugin_descriptor_t* descriptor_;
};

// Every plugin found in a list of directories, keyed by name. Files that fail to load are
// recorded in rejected() ("file: cause") and never abort the scan.
class PluginCatalog : public PluginSet<PluginLibrary> {
 public:
  PluginCatalog() = default;
  explicit PluginCatalog(const std::vector<std::filesystem::path>& directories,
                         uint32_t supported_kinds = kAllMeasurementKinds);

  // Creates an instance; an unknown name is a ConfigError listing the known plugins.
  LocalizerPtr create(const std::string& name) const;
};

// Creates, configures and returns a localizer; a throwing configure keeps its ConfigError type,
// anything else it throws becomes a ConfigError naming the plugin.
LocalizerPtr create_configured(const PluginCatalog& catalog, const std::string& plugin,
                               const PluginContext& context, const Params& params);
LocalizerPtr create_configured(const PluginLibrary& library, const PluginContext& context, const Params& params);

}  // namespace locd
