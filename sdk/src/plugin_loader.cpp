#include "locd/sdk/plugin_loader.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <regex>

namespace locd {
namespace fs = std::filesystem;

// ------------------------------------------------------------------------- MapResolver

MapResolver::MapResolver(std::vector<fs::path> directories) : directories_(std::move(directories)) {}

fs::path MapResolver::resolve(const std::string& name) const {
  const fs::path requested(name);
  if (name.empty()) throw ConfigError("map file name is empty");
  if (requested.is_absolute()) {
    throw ConfigError("map file '" + name +
                      "' is an absolute path; name a file relative to the server's map directories");
  }
  for (const auto& part : requested) {
    if (part == "..") {
      throw ConfigError("map file '" + name + "' contains '..'; only files inside the map directories are allowed");
    }
  }
  std::string searched;
  for (const auto& dir : directories_) {
    std::error_code ec;
    const fs::path root = fs::weakly_canonical(dir, ec);
    if (ec) continue;
    const fs::path candidate = fs::weakly_canonical(root / requested, ec);
    searched += (searched.empty() ? "" : ", ") + root.string();
    if (ec || !fs::is_regular_file(candidate, ec)) continue;
    // After following links the file must still lie inside the directory.
    const auto rel = candidate.lexically_relative(root);
    if (rel.empty() || *rel.begin() == "..") {
      throw ConfigError("map file '" + name + "' resolves outside the map directory " + root.string());
    }
    return candidate;
  }
  throw ConfigError("map file '" + name + "' not found in the map directories [" + searched + "]");
}

// ------------------------------------------------------------------------- PluginLibrary

void LocalizerDeleter::operator()(Localizer* instance) const {
  if (!instance) return;
  if (library) {
    library->descriptor().destroy(instance);
  } else {
    delete instance;  // made in this process without a library (e.g. a test's localizer)
  }
}

PluginLibrary::PluginLibrary(void* handle, fs::path file, const locd_plugin_descriptor_t* d)
    : handle_(handle), file_(std::move(file)), descriptor_(d) {}

PluginLibrary::~PluginLibrary() {
  if (handle_) dlclose(handle_);
}

std::shared_ptr<PluginLibrary> PluginLibrary::open(const fs::path& file, uint32_t supported_kinds) {
  const std::string where = file.string();
  void* handle = dlopen(where.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* err = dlerror();
    throw PluginLoadError(where + ": cannot load: " + (err ? err : "unknown dlopen error"));
  }
  auto fail = [&](const std::string& cause) {
    dlclose(handle);
    throw PluginLoadError(where + ": " + cause);
  };
  using Entry = const locd_plugin_descriptor_t* (*)();
  auto entry = reinterpret_cast<Entry>(dlsym(handle, LOCD_PLUGIN_ENTRY_POINT));
  if (!entry) fail("no entry point '" LOCD_PLUGIN_ENTRY_POINT "' (build it with LOCD_REGISTER_PLUGIN)");
  const locd_plugin_descriptor_t* d = entry();
  if (!d) fail("entry point returned no descriptor");
  if (d->abi_version != LOCD_PLUGIN_ABI_VERSION) {
    fail("ABI version " + std::to_string(d->abi_version) + ", the server speaks " +
         std::to_string(LOCD_PLUGIN_ABI_VERSION) + "; rebuild the plugin against this SDK");
  }
  static const std::regex valid_name("[a-z][a-z0-9_]{0,63}");
  if (!d->name || !std::regex_match(d->name, valid_name)) {
    fail(std::string("invalid plugin name '") + (d->name ? d->name : "") + "'; expected [a-z][a-z0-9_]*");
  }
  if (!d->create || !d->destroy) fail("descriptor has no factory");
  if (d->consumes == 0) fail("plugin '" + std::string(d->name) + "' consumes no measurement kind");
  if (d->consumes & ~supported_kinds) {
    const auto missing = kind_names(d->consumes & ~supported_kinds);
    std::string names;
    for (const auto& n : missing) names += (names.empty() ? "" : ", ") + n;
    if (names.empty()) names = "unknown kind bits " + std::to_string(d->consumes & ~supported_kinds);
    fail("plugin '" + std::string(d->name) + "' needs inputs this server cannot give: " + names);
  }
  return std::shared_ptr<PluginLibrary>(new PluginLibrary(handle, file, d));
}

LocalizerPtr PluginLibrary::create() const {
  Localizer* instance = nullptr;
  try {
    instance = descriptor_->create();
  } catch (const std::exception& e) {
    throw PluginLoadError(file_.string() + ": factory of plugin '" + name() + "' threw: " + e.what());
  } catch (...) {
    throw PluginLoadError(file_.string() + ": factory of plugin '" + name() + "' threw a non-standard exception");
  }
  if (!instance) throw PluginLoadError(file_.string() + ": factory of plugin '" + name() + "' returned null");
  return LocalizerPtr(instance, LocalizerDeleter{shared_from_this()});
}

// ------------------------------------------------------------------------- PluginCatalog

PluginCatalog::PluginCatalog(const std::vector<fs::path>& directories, uint32_t supported_kinds) {
  scan(directories, [&](const fs::path& file) {
    std::shared_ptr<const PluginLibrary> library = PluginLibrary::open(file, supported_kinds);
    return std::make_pair(library->name(), library);
  });
}

LocalizerPtr PluginCatalog::create(const std::string& name) const { return require(name)->create(); }

LocalizerPtr create_configured(const PluginLibrary& library, const PluginContext& context, const Params& params) {
  LocalizerPtr instance;
  try {
    instance = library.create();
  } catch (const PluginLoadError& e) {
    throw ConfigError(e.what());
  }
  const std::string plugin = library.name();
  try {
    instance->configure(context, params);
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError("plugin '" + plugin + "' (" + library.file().string() + ") failed to configure: " + e.what());
  } catch (...) {
    throw ConfigError("plugin '" + plugin + "' (" + library.file().string() +
                      ") failed to configure with a non-standard exception");
  }
  return instance;
}

LocalizerPtr create_configured(const PluginCatalog& catalog, const std::string& plugin,
                               const PluginContext& context, const Params& params) {
  return create_configured(*catalog.require(plugin), context, params);
}

}  // namespace locd
