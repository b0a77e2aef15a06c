// Plugins by name, read from the `.so` files of plugin directories: the one place that scans the
// directories and answers "which plugin is that name". The sdk's PluginCatalog keeps loaded
// libraries (a worker, `locsim run`); the server's PluginIndex keeps descriptions read by an
// inspector process, so locd never maps plugin code.
#pragma once

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "locd/sdk/errors.hpp"

namespace locd {

template <class Entry>
class PluginSet {
 public:
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& [name, _] : plugins_) out.push_back(name);
    return out;
  }
  std::shared_ptr<const Entry> find(const std::string& name) const {  // null if absent
    const auto it = plugins_.find(name);
    return it == plugins_.end() ? nullptr : it->second.entry;
  }
  // An unknown name is a ConfigError listing the known plugins.
  std::shared_ptr<const Entry> require(const std::string& name) const {
    auto entry = find(name);
    if (!entry) {
      std::string known;
      for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
      throw ConfigError("unknown plugin '" + name + "'; known plugins: " + (known.empty() ? "(none)" : known));
    }
    return entry;
  }
  // "file: cause" for every directory that does not exist, file that failed and second file of
  // a name; none of them aborts the scan.
  const std::vector<std::string>& rejected() const { return rejected_; }

 protected:
  // Reads every `.so` of `directories` (per directory in file-name order; the first file of a
  // name wins) with `read(file)`, which returns {name, entry} or throws PluginLoadError.
  template <class Read>
  void scan(const std::vector<std::filesystem::path>& directories, Read&& read) {
    namespace fs = std::filesystem;
    for (const auto& dir : directories) {
      std::error_code ec;
      if (!fs::is_directory(dir, ec)) {
        rejected_.push_back(dir.string() + ": plugin directory does not exist");
        continue;
      }
      std::vector<fs::path> files;
      for (const auto& file : fs::directory_iterator(dir, ec)) {
        if (file.is_regular_file() && file.path().extension() == ".so") files.push_back(file.path());
      }
      std::sort(files.begin(), files.end());
      for (const auto& file : files) {
        try {
          auto [name, entry] = read(file);
          if (const auto it = plugins_.find(name); it != plugins_.end()) {
            rejected_.push_back(file.string() + ": plugin '" + name + "' already loaded from " + it->second.file.string());
            continue;
          }
          plugins_.emplace(name, Found{file, std::move(entry)});
        } catch (const PluginLoadError& e) {
          rejected_.push_back(e.what());
        }
      }
    }
  }

 private:
  struct Found {
    std::filesystem::path file;
    std::shared_ptr<const Entry> entry;
  };
  std::map<std::string, Found> plugins_;
  std::vector<std::string> rejected_;
};

}  // namespace locd
