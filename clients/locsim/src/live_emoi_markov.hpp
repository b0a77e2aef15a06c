// `locsim live` for emoi_markov's four-position experiment (kind: emoi_four_positions): each run's
// DSM is written as a GeoTIFF into $LOCD_SIM_MAP_DIR (default /tmp/locd_sim_maps; the server must
// list it in map_directories), the session is requested with the scenario's plugin config naming
// that file, and odometry, IMU and scans stream in real time (--rate); the pose of each sensor
// update (the pose stamped like the scan that triggered it) is compared with the truth.
#pragma once

#include <filesystem>
#include <optional>

#include "live.hpp"

namespace locd::sim {

int run_four_positions_live(const std::filesystem::path& scenario_file, const LiveOptions& options,
                            std::optional<uint64_t> seed, bool json);

}  // namespace locd::sim
