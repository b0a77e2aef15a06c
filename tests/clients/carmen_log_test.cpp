// locd_logs' CARMEN reader: a committed excerpt of a real log (tests/clients/data, origin in its
// first line), gzip through zlib, and every bad line named by file, line and field.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "locd/logs/carmen_log.hpp"
#include "test_env.hpp"

namespace {

using namespace locd;
using namespace locd::logs;

std::string excerpt() { return test::source_dir() + "/tests/clients/data/freiburg-079_excerpt.log"; }

std::string error_of(const std::string& text, const CarmenReadOptions& options = {}) {
  std::istringstream in(text);
  try {
    parse_carmen_log(in, "bad.log", options);
  } catch (const LogError& e) {
    return e.what();
  }
  return "";
}

std::string flaser(int n, const std::string& tail) {
  std::string line = "FLASER " + std::to_string(n);
  for (int i = 0; i < n; ++i) line += " 1.5";
  return line + " " + tail + "\n";
}

TEST(CarmenLog, ReadsTheRealExcerpt) {
  const CarmenLog log = read_carmen_log(excerpt());
  ASSERT_EQ(log.scans.size(), 3u);
  const CarmenScan& s = log.scans.front();
  EXPECT_EQ(s.line, 4u);  // after the origin comment and two ODOM lines
  EXPECT_EQ(s.scan.ranges.size(), 360u);
  EXPECT_FLOAT_EQ(s.scan.ranges[0], 1.65f);
  EXPECT_NEAR(s.laser_pose.x, 0.00123601, 1e-9);
  EXPECT_NEAR(s.laser_pose.y, -0.00106807, 1e-9);
  EXPECT_NEAR(s.laser_pose.theta, 2.85e-05, 1e-12);
  EXPECT_EQ(s.scan.header.stamp_ns, 227'623'000);
  EXPECT_NEAR(s.scan.angle_min, -M_PI / 2, 1e-6);
  EXPECT_NEAR(s.scan.angle_increment, M_PI / 360, 1e-7);  // 0.5 deg
  EXPECT_EQ(log.scans[1].scan.header.stamp_ns, 468'274'000);
  // ODOM: the stamp-0 repeats skipped and counted, the others kept in order.
  EXPECT_EQ(log.zero_stamp_odometry, 3u);
  ASSERT_EQ(log.odometry.size(), 4u);
  EXPECT_EQ(log.odometry[0].stamp_ns, 15'885'000);
  EXPECT_EQ(log.odometry[2].stamp_ns, 468'274'000);
  EXPECT_NEAR(log.odometry[2].pose.x, 0.00203275, 1e-9);
  EXPECT_EQ(log.skipped.at("NEFF"), 2u);
}

TEST(CarmenLog, GzipReadsAsPlainAndNoReturnsAreInfinite) {
  const std::filesystem::path gz = std::filesystem::temp_directory_path() / "locd_carmen_test.log.gz";
  {
    std::ifstream in(excerpt(), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    std::string content = text.str() + flaser(4, "1 2 0.5 1 2 0.5 9.5 host 9.5");
    content.replace(content.rfind("1.5 1 2"), 3, "81.83");  // the saturation value
    gzFile out = gzopen(gz.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    ASSERT_EQ(gzwrite(out, content.data(), static_cast<unsigned>(content.size())), static_cast<int>(content.size()));
    gzclose(out);
  }
  const CarmenLog log = read_carmen_log(gz);
  std::filesystem::remove(gz);
  ASSERT_EQ(log.scans.size(), 4u);
  const LaserScan& last = log.scans.back().scan;
  EXPECT_TRUE(std::isinf(last.ranges[3]));
  EXPECT_EQ(last.reading(3), RangeReading::kNoReturn);
  EXPECT_EQ(last.reading(0), RangeReading::kHit);
  EXPECT_NEAR(last.angle_increment, M_PI / 4, 1e-6);
}

TEST(CarmenLog, RobotLaserCarriesItsAnglesAndMount) {
  std::istringstream in(
      "ROBOTLASER1 0 -1.5 3.0 0.5 50 0.01 0 7 1 2 3 4 5 6 7 0 "
      "1.1 2.0 0.0 1.0 2.0 0.0 0.1 0 0.5 0.5 0 12.5 host 12.5\n");
  const CarmenLog log = parse_carmen_log(in, "robot.log");
  ASSERT_EQ(log.scans.size(), 1u);
  const CarmenScan& s = log.scans[0];
  EXPECT_FLOAT_EQ(s.scan.angle_min, -1.5f);
  EXPECT_FLOAT_EQ(s.scan.angle_increment, 0.5f);
  EXPECT_EQ(s.scan.ranges.size(), 7u);
  EXPECT_NEAR(s.scan.sensor_pose.translation().x(), 0.1, 1e-12);  // laser 0.1 m ahead of the robot
  EXPECT_EQ(s.scan.header.stamp_ns, 12'500'000'000);
}

TEST(CarmenLog, BadLinesNameFileLineAndField) {
  const std::string good = flaser(3, "1 2 0.5 1 2 0.5 10.0 host 10.0");
  std::string e = error_of("# comment\n" + flaser(3, "1 x 0.5 1 2 0.5 10.0 host 10.0"));
  EXPECT_NE(e.find("bad.log:2: FLASER: field 'y'"), std::string::npos) << e;
  EXPECT_NE(e.find("'x' is not a finite number"), std::string::npos) << e;
  e = error_of("FLASER 3 1 2\n");
  EXPECT_NE(e.find("bad.log:1"), std::string::npos) << e;
  EXPECT_NE(e.find("field 'range 3'"), std::string::npos) << e;
  EXPECT_NE(e.find("missing"), std::string::npos) << e;
  e = error_of("FLASER 2.5 1 2\n");
  EXPECT_NE(e.find("'num_readings'"), std::string::npos) << e;
  e = error_of(good + flaser(3, "1 2 0.5 1 2 0.5 9.0 host 9.0"));
  EXPECT_NE(e.find("bad.log:2: FLASER: field 'ipc_timestamp' = 9.000000 s goes backwards"), std::string::npos) << e;
  EXPECT_NE(e.find("line 1"), std::string::npos) << e;
  e = error_of("ODOM 1 2 3 0 0 0 5 host 5\nODOM 1 2 3 0 0 0 4 host 4\n");
  EXPECT_NE(e.find("bad.log:2: ODOM: field 'ipc_timestamp'"), std::string::npos) << e;
  e = error_of("ODOM 1 2 3 0 0 0 -4 host -4\n");
  EXPECT_NE(e.find("negative"), std::string::npos) << e;
  e = error_of("ODOM 1 2 3 0 0 0 5 host 5 extra\n");
  EXPECT_NE(e.find("after 'logger_timestamp'"), std::string::npos) << e;
  e = error_of(flaser(3, "1 2 0.5 1 2 0.5 10.0 host 10.0").replace(9, 3, "-1"));
  EXPECT_NE(e.find("negative"), std::string::npos) << e;
  // Going backwards skipped and counted when asked (the corrected logs' repeats).
  CarmenReadOptions skip;
  skip.skip_going_backwards = true;
  std::istringstream in(good + flaser(3, "1 2 0.5 1 2 0.5 9.0 host 9.0") + "ODOM 1 2 3 0 0 0 5 host 5\n"
                        "ODOM 1 2 3 0 0 0 -1 host -1\nODOM 1 2 3 0 0 0 6 host 6\n");
  const CarmenLog log = parse_carmen_log(in, "ok.log", skip);
  EXPECT_EQ(log.scans.size(), 1u);
  EXPECT_EQ(log.scans_going_backwards, 1u);
  EXPECT_EQ(log.odometry.size(), 2u);
  EXPECT_EQ(log.odometry_going_backwards, 1u);
  // A missing file.
  EXPECT_THROW(read_carmen_log("/nonexistent/locd.log.gz"), LogError);
}

}  // namespace
