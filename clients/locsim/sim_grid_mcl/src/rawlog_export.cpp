#include "locd/sim_grid_mcl/rawlog_export.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "locd/sim/simulation.hpp"

extern char** environ;

namespace locd::sim::grid {

namespace fs = std::filesystem;

std::string carmen_robotlaser_line(const LaserScan& scan, const Pose2& odometry, double t) {
  const size_t n = scan.ranges.size();
  if (n < 2) throw std::invalid_argument("carmen export: a scan needs at least 2 beams");
  const double last = scan.angle(n - 1);
  if (std::abs(scan.angle_min + last) > 1e-4) {
    throw std::invalid_argument("carmen export: MRPT expects a scan symmetric about the laser's x axis");
  }
  const double fov = last - scan.angle_min;
  const Pose2 mount = Pose2::from_isometry(scan.sensor_pose);
  const Pose2 laser = odometry * mount;
  std::string line;
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "ROBOTLASER1 3 %.9f %.9f %.9f %.3f 0.01 0 %zu", scan.angle_min, fov,
                static_cast<double>(scan.angle_increment), static_cast<double>(scan.range_max), n);
  line += buffer;
  for (size_t i = 0; i < n; ++i) {
    const double r = scan.valid_return(i) ? scan.ranges[i] : scan.range_max;
    std::snprintf(buffer, sizeof buffer, " %.4f", r);
    line += buffer;
  }
  std::snprintf(buffer, sizeof buffer, " 0 %.6f %.6f %.9f %.6f %.6f %.9f 0 0 0 0 0 %.6f locsim %.6f", laser.x, laser.y,
                laser.theta, odometry.x, odometry.y, odometry.theta, t, t);
  line += buffer;
  return line;
}

int run_program(const std::vector<std::string>& argv, const fs::path& log_file) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  pid_t pid = 0;
  const int started = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (started != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

RawlogExport export_rawlog(const Scenario& scenario, uint64_t seed, double duration_s, const fs::path& rawlog_file) {
  RawlogExport out;
  out.rawlog = rawlog_file;
  out.carmen_log = fs::path(rawlog_file).replace_extension(".carmen.log");
  out.truth = fs::path(rawlog_file).replace_extension(".truth.txt");
  std::ofstream log(out.carmen_log), truth(out.truth);
  if (!log || !truth) throw std::runtime_error("cannot write next to '" + rawlog_file.string() + "'");
  truth << "# t x y yaw: the truth at each scan of " << rawlog_file.filename().string() << "\n";
  Simulation simulation(scenario, seed, duration_s);
  std::optional<Pose2> odometry;
  while (auto m = simulation.next()) {
    if (const auto* o = std::get_if<Odometry>(&m->measurement)) {
      odometry = Pose2::from_isometry(o->pose);
    } else if (const auto* scan = std::get_if<LaserScan>(&m->measurement)) {
      if (!odometry) continue;  // pf-localization pairs every scan with an odometry reading
      log << carmen_robotlaser_line(*scan, *odometry, m->t) << "\n";
      const Pose2 p = simulation.truth().at(m->t).pose;
      char buffer[128];
      std::snprintf(buffer, sizeof buffer, "%.6f %.6f %.6f %.9f\n", m->t, p.x, p.y, p.theta);
      truth << buffer;
      ++out.scans;
    }
  }
  log.close();
  truth.close();
  if (!log || !truth) throw std::runtime_error("cannot write the CARMEN log or the truth of '" + rawlog_file.string() + "'");
  const fs::path conversion_log = fs::path(rawlog_file).replace_extension(".carmen2rawlog.txt");
  fs::remove(conversion_log);
  const int status = run_program({"carmen2rawlog", "-w", "-q", "-i", out.carmen_log.string(), "-o", rawlog_file.string()},
                                 conversion_log);
  if (status != 0) {
    throw std::runtime_error(status < 0 ? "carmen2rawlog not found: install Debian's mrpt-apps (scripts/bootstrap does)"
                                        : "carmen2rawlog failed (status " + std::to_string(status) + "), see '" +
                                              conversion_log.string() + "'");
  }
  // carmen2rawlog also saves the odometry paired with each scan as FILE.gt.txt ("ground truth"
  // to CARMEN logs of corrected poses); here it is the odometry, and the truth is FILE.truth.txt.
  fs::remove(fs::path(rawlog_file).replace_extension(".gt.txt"));
  return out;
}

}  // namespace locd::sim::grid
