// Shared helpers for tests: where the tree and the build are, and DDS domain ids.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace locd::test {

inline std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}
inline std::string source_dir() { return env_or("LOCD_SOURCE_DIR", "."); }
inline std::string binary_dir() { return env_or("LOCD_BINARY_DIR", "build"); }
inline std::string plugin_dir() { return env_or("LOCD_PLUGIN_DIR", "build/plugins"); }

// A whole text file (e.g. a shipped plugin config); empty when it cannot be read.
inline std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Domain ids: every DDS test names its own constant from this table, so tests run in parallel
// without seeing each other's data. Keep them unique across the whole tree.
//   10-19 tests/integration end to end      30-39 locsim            40-49 client library, locctl
//   50-69 server (bad input, CLI)           80-84 ceiling_pf        85-89 emoi_markov
//   90-94 icp_explorer                      95-99 feature_ekf landmarks
//   100-119 fault isolation                 120-123 security, session ownership
//   124-129 Foxglove view, MCAP record/replay; 128 view access (tokens, origins)
//   130-139 grid_mcl                        140-149 ROS 2 and Fast DDS interoperability
//   150-179 fleet                           180-189 honest accuracy
//   190-199 addressing (partitions, robot ids)  205 session pinning  206-207 request floods (rate limits)  208 discovery data  210 encrypted RTPS messages (security)
//   223-227 worker faults and restarts (issue 27)  228-230 fleet stall, ownership; 229 FleetHosts stall
//   217-222 ROS 2 as a Nav2 AMCL drop-in (issue 24)
//   213-216 ROS 2 bag replay (issue 21; DDS allows domain ids up to 232 only)
//   231 worker sandbox (issue 23: the range it was given, 235-242, lies past Cyclone's last domain, 232)
//   0 the demo (LOCD_DOMAIN overrides)
}  // namespace locd::test
