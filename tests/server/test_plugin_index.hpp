// The server's plugin index of a test's plugin directory, read as locd reads it: each file by a
// sandboxed `locd-worker --inspect` (LOCD_WORKER_EXECUTABLE), never loaded into the test.
#pragma once

#include <string>

#include "locd/server/plugin_index.hpp"

namespace locd::server::test {

inline PluginIndex plugin_index(const std::string& directory) {
  static Logger logger(LogLevel::kWarning);
  InspectorSettings settings;
  settings.executable = LOCD_WORKER_EXECUTABLE;
  settings.sandbox.readable = {directory};
  return PluginIndex({directory}, settings, logger);
}

}  // namespace locd::server::test
