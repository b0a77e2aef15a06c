// A simulated run as an MRPT rawlog, for MRPT's pf-localization (Debian mrpt-apps). locsim writes
// the run as a CARMEN log (one ROBOTLASER1 line per scan: the ranges, the laser's and the robot's
// odometry pose at the scan's stamp, the time) and converts it with MRPT's own carmen2rawlog into
// an observations-only rawlog (odometry + 2D range scan pairs). The truth at each scan goes to a
// side file "t x y yaw" per line, for scoring. The simulation is deterministic per seed, so the
// rawlog holds exactly the scans and odometry `locsim run` feeds the plugin.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim/scenario.hpp"

namespace locd::sim::grid {

struct RawlogExport {
  size_t scans = 0;
  std::filesystem::path carmen_log, rawlog, truth;
};

// Writes FILE.carmen.log and FILE.truth.txt next to rawlog_file, then runs carmen2rawlog; throws
// std::runtime_error naming what failed (e.g. carmen2rawlog missing: install mrpt-apps).
RawlogExport export_rawlog(const Scenario& scenario, uint64_t seed, double duration_s,
                           const std::filesystem::path& rawlog_file);

// One CARMEN ROBOTLASER1 line (ranges beyond range_max or without return written as range_max).
// The scan must be symmetric about the laser's x axis (MRPT's assumption); std::invalid_argument
// otherwise.
std::string carmen_robotlaser_line(const LaserScan& scan, const Pose2& odometry, double t);

// Runs a program (PATH lookup) with its output appended to log_file; returns its exit status
// (-1: could not start).
int run_program(const std::vector<std::string>& argv, const std::filesystem::path& log_file);

}  // namespace locd::sim::grid
