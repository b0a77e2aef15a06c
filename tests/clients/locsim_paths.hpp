// The tree and plugin directory for the locsim tests: the test environment's, else the build's.
#pragma once

#include <string>

#include "test_env.hpp"

namespace locd::sim::test {
inline std::string source_dir() { return locd::test::env_or("LOCD_SOURCE_DIR", LOCSIM_TEST_SOURCE_DIR); }
inline std::string binary_dir() { return locd::test::env_or("LOCD_BINARY_DIR", LOCSIM_TEST_BINARY_DIR); }
inline std::string plugin_dir() { return locd::test::env_or("LOCD_PLUGIN_DIR", LOCSIM_TEST_PLUGIN_DIR); }
}  // namespace locd::sim::test
