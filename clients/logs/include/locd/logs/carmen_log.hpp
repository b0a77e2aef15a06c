// CARMEN robot logs (the format of Radish's data sets and of CARMEN's logger), read into sdk
// measurements. Plain text or gzip (zlib reads both). One message per line, fields separated by
// white space:
//
//   FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//   ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
//               n r_1 .. r_n m v_1 .. v_m laser_x laser_y laser_theta robot_x robot_y robot_theta
//               tv rv forward_safety_dist side_safety_dist turn_axis ipc_timestamp host logger_timestamp
//   ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
//
// FLASER carries no angles: its n beams span `flaser_field_of_view` (180 deg) from
// -field_of_view / 2, n readings of field_of_view / n each (as MRPT's and GMapping's readers).
// Readings at or above `no_return_range` (the SICK's saturation value, about 81.9 m) are no
// returns: they are given as +inf (REP 117). Stamps are the ipc_timestamp (s) in nanoseconds.
//
// Every other message type (PARAM, SYNC, NEFF, TRUEPOS, ...) and comment lines are skipped and
// counted. An ODOM line whose stamp is 0 (corrected logs repeat the corrected pose after each
// scan with stamp 0) is skipped and counted too. A line of a type read here that does not parse,
// or whose stamp goes backwards against the previous message of its type, is an error naming the
// file, the line, the field and what was expected.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <istream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "locd/sdk/geometry.hpp"
#include "locd/sdk/types.hpp"

namespace locd::logs {

class LogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CarmenScan {
  size_t line = 0;    // in the file, from 1
  LaserScan scan;     // header.stamp_ns, frame "laser"; the laser at the robot's origin (FLASER)
                      // or at laser_pose relative to robot_pose (ROBOTLASER1)
  Pose2 laser_pose;   // FLASER x y theta / ROBOTLASER1 laser_x .. (in corrected logs: the reference)
  Pose2 robot_pose;   // FLASER odom_x .. / ROBOTLASER1 robot_x ..
};

struct CarmenOdometry {
  size_t line = 0;
  int64_t stamp_ns = 0;
  Pose2 pose;
  double translational_velocity = 0.0;  // m/s
  double rotational_velocity = 0.0;     // rad/s
};

struct CarmenReadOptions {
  double flaser_field_of_view = M_PI;  // rad
  double no_return_range = 81.0;       // m: readings at or above are no return
  double range_max = 80.0;             // m: the scans' range_max (hits lie below it)
  // Corrected logs repeat the corrected pose after a scan, mostly with stamp 0 but now and then
  // with a stamp from elsewhere (freiburg-079 line 19411: 5.36 s after 1055.12 s), and intel's
  // stamps step back a little four times (line 5647: a scan at 940.54 s after one at 940.654 s):
  // true skips and counts an ODOM or scan line older than the previous one of its kind (or, for
  // ODOM, negative) instead of failing.
  bool skip_going_backwards = false;
};

struct CarmenLog {
  std::vector<CarmenScan> scans;         // FLASER and ROBOTLASER1, in file order
  std::vector<CarmenOdometry> odometry;  // ODOM with a stamp above 0, in file order
  size_t zero_stamp_odometry = 0;        // ODOM lines with stamp 0, skipped
  size_t odometry_going_backwards = 0;   // skipped (skip_going_backwards)
  size_t scans_going_backwards = 0;      // skipped (skip_going_backwards)
  std::map<std::string, size_t> skipped;  // other message types, by name
};

// `name` is the file name the errors give.
CarmenLog parse_carmen_log(std::istream& in, const std::string& name, const CarmenReadOptions& options = {});
// Reads a file (gzip or plain); LogError when it cannot be opened or read.
CarmenLog read_carmen_log(const std::filesystem::path& file, const CarmenReadOptions& options = {});

}  // namespace locd::logs
