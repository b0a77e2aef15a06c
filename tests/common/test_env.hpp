// Shared helpers for tests: where the tree and the build are, and DDS domain ids.
#pragma once

#include <cstdlib>
#include <string>

namespace locd::test {

inline std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}
inline std::string source_dir() { return env_or("LOCD_SOURCE_DIR", "."); }
inline std::string binary_dir() { return env_or("LOCD_BINARY_DIR", "build"); }
inline std::string plugin_dir() { return env_or("LOCD_PLUGIN_DIR", "build/plugins"); }

// Domain ids: every DDS test names its own constant from this table, so tests run in parallel
// without seeing each other's data. Keep them unique across the whole tree.
//   10-29 tests/integration, 30-49 tests/clients, 50-69 tests/server, 70-79 tests/plugins
//   100-119 bench, 0 demo
}  // namespace locd::test
