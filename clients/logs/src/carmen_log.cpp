#include "locd/logs/carmen_log.hpp"

#include <zlib.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "locd/sdk/text.hpp"

namespace locd::logs {
namespace {

// The fields of one line, with where the errors point.
class LineFields {
 public:
  LineFields(const std::string& name, size_t line, std::vector<std::string> tokens)
      : name_(name), line_(line), tokens_(std::move(tokens)) {}

  const std::string& type() const { return tokens_[0]; }

  [[noreturn]] void fail(const std::string& what) const {
    throw LogError(escaped(name_) + ":" + std::to_string(line_) + ": " + escaped(type(), 32) + ": " + what);
  }

  const std::string& token(const std::string& field) {
    if (next_ >= tokens_.size()) {
      fail("field '" + field + "' (field " + std::to_string(next_) + ") is missing: the line ends after " +
           std::to_string(tokens_.size() - 1) + " fields");
    }
    return tokens_[next_++];
  }

  double number(const std::string& field) {
    const std::string& text = token(field);
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
      fail("field '" + field + "' (field " + std::to_string(next_ - 1) + ") = '" + escaped(text, 32) +
           "' is not a finite number");
    }
    return value;
  }

  size_t count(const std::string& field, size_t most) {
    const double value = number(field);
    if (!(value >= 0.0) || value != std::floor(value) || value > static_cast<double>(most)) {
      fail("field '" + field + "' (field " + std::to_string(next_ - 1) + ") = " + token_at(next_ - 1) +
           " must be a whole number from 0 to " + std::to_string(most));
    }
    return static_cast<size_t>(value);
  }

  int64_t stamp(const std::string& field, bool allow_negative = false) {
    const double seconds = number(field);
    if ((seconds < 0.0 && !allow_negative) || std::abs(seconds) > 1e10) {
      fail("field '" + field + "' = " + token_at(next_ - 1) + " s is not a stamp from 0 to 1e10 s");
    }
    return static_cast<int64_t>(std::llround(seconds * 1e9));
  }

  // The host and logger_timestamp close every message; both are read (a truncated line fails).
  void trailer() {
    token("host");
    number("logger_timestamp");
    if (next_ != tokens_.size()) {
      fail("has " + std::to_string(tokens_.size() - next_) + " fields after 'logger_timestamp', expected none");
    }
  }

 private:
  std::string token_at(size_t i) const { return escaped(tokens_[i], 32); }

  const std::string& name_;
  size_t line_;
  std::vector<std::string> tokens_;
  size_t next_ = 1;
};

constexpr size_t kMostReadings = 100000;

std::vector<float> read_ranges(LineFields& f, size_t n, const CarmenReadOptions& options) {
  std::vector<float> ranges(n);
  for (size_t i = 0; i < n; ++i) {
    const double r = f.number("range " + std::to_string(i + 1));
    if (r < 0.0) f.fail("range " + std::to_string(i + 1) + " = " + std::to_string(r) + " is negative");
    ranges[i] = r >= options.no_return_range ? std::numeric_limits<float>::infinity() : static_cast<float>(r);
  }
  return ranges;
}

Pose2 read_pose(LineFields& f, const std::string& prefix) {
  const double x = f.number(prefix + "x"), y = f.number(prefix + "y"), theta = f.number(prefix + "theta");
  return Pose2(x, y, normalize_angle(theta));
}

CarmenScan read_flaser(LineFields& f, size_t line, const CarmenReadOptions& options) {
  CarmenScan s;
  s.line = line;
  const size_t n = f.count("num_readings", kMostReadings);
  if (n < 2) f.fail("num_readings = " + std::to_string(n) + ": a scan needs at least 2");
  s.scan.ranges = read_ranges(f, n, options);
  s.laser_pose = read_pose(f, "");
  s.robot_pose = read_pose(f, "odom_");
  s.scan.header.stamp_ns = f.stamp("ipc_timestamp");
  f.trailer();
  s.scan.angle_increment = static_cast<float>(options.flaser_field_of_view / static_cast<double>(n));
  s.scan.angle_min = static_cast<float>(-0.5 * options.flaser_field_of_view);
  return s;
}

CarmenScan read_robotlaser(LineFields& f, size_t line, const CarmenReadOptions& options) {
  CarmenScan s;
  s.line = line;
  f.number("laser_type");
  const double start = f.number("start_angle");
  f.number("field_of_view");
  const double resolution = f.number("angular_resolution");
  if (!(resolution > 0.0)) f.fail("angular_resolution = " + std::to_string(resolution) + " must be above 0");
  const double max_range = f.number("maximum_range");
  f.number("accuracy");
  f.number("remission_mode");
  const size_t n = f.count("num_readings", kMostReadings);
  if (n < 2) f.fail("num_readings = " + std::to_string(n) + ": a scan needs at least 2");
  CarmenReadOptions own = options;
  if (max_range > 0.0) own.no_return_range = std::min(options.no_return_range, max_range);
  s.scan.ranges = read_ranges(f, n, own);
  const size_t m = f.count("num_remissions", kMostReadings);
  for (size_t i = 0; i < m; ++i) f.number("remission " + std::to_string(i + 1));
  s.laser_pose = read_pose(f, "laser_pose_");
  s.robot_pose = read_pose(f, "robot_pose_");
  for (const char* field : {"tv", "rv", "forward_safety_dist", "side_safety_dist", "turn_axis"}) f.number(field);
  s.scan.header.stamp_ns = f.stamp("ipc_timestamp");
  f.trailer();
  s.scan.angle_min = static_cast<float>(start);
  s.scan.angle_increment = static_cast<float>(resolution);
  // The laser's mount: where it sits on the robot (both poses are in the same world frame).
  const Pose2 mount = s.robot_pose.inverse() * s.laser_pose;
  s.scan.sensor_pose = mount.to_isometry();
  return s;
}

CarmenOdometry read_odom(LineFields& f, size_t line) {
  CarmenOdometry o;
  o.line = line;
  o.pose = read_pose(f, "");
  o.translational_velocity = f.number("tv");
  o.rotational_velocity = f.number("rv");
  f.number("accel");
  o.stamp_ns = f.stamp("ipc_timestamp", true);  // a negative one is going backwards (below)
  f.trailer();
  return o;
}

}  // namespace

CarmenLog parse_carmen_log(std::istream& in, const std::string& name, const CarmenReadOptions& options) {
  if (!(options.flaser_field_of_view > 0.0 && options.flaser_field_of_view <= 2.0 * M_PI)) {
    throw LogError("flaser_field_of_view must be in (0, 2 pi]");
  }
  if (!(options.range_max > 0.0 && options.no_return_range >= options.range_max)) {
    throw LogError("range_max must be above 0 and at most no_return_range");
  }
  CarmenLog log;
  std::string text;
  size_t line = 0;
  int64_t last_scan = std::numeric_limits<int64_t>::min(), last_odometry = std::numeric_limits<int64_t>::min();
  size_t last_scan_line = 0, last_odometry_line = 0;
  const auto backwards = [&](const LineFields& f, int64_t stamp, int64_t previous, size_t previous_line) {
    f.fail("field 'ipc_timestamp' = " + std::to_string(static_cast<double>(stamp) * 1e-9) +
           " s goes backwards: the previous message of its kind (line " + std::to_string(previous_line) + ") was at " +
           std::to_string(static_cast<double>(previous) * 1e-9) + " s");
  };
  while (std::getline(in, text)) {
    ++line;
    std::istringstream words(text);
    std::vector<std::string> tokens;
    for (std::string w; words >> w;) tokens.push_back(std::move(w));
    if (tokens.empty() || tokens[0][0] == '#') continue;
    LineFields f(name, line, std::move(tokens));
    const std::string type = f.type();
    if (type == "FLASER" || type == "ROBOTLASER1") {
      CarmenScan s = type == "FLASER" ? read_flaser(f, line, options) : read_robotlaser(f, line, options);
      s.scan.range_min = 0.0f;
      s.scan.range_max = static_cast<float>(options.range_max);
      s.scan.header.frame_id = "laser";
      if (s.scan.header.stamp_ns < last_scan) {
        if (!options.skip_going_backwards) backwards(f, s.scan.header.stamp_ns, last_scan, last_scan_line);
        ++log.scans_going_backwards;
        continue;
      }
      last_scan = s.scan.header.stamp_ns;
      last_scan_line = line;
      log.scans.push_back(std::move(s));
    } else if (type == "ODOM") {
      const CarmenOdometry o = read_odom(f, line);
      if (o.stamp_ns == 0) {
        ++log.zero_stamp_odometry;
        continue;
      }
      if (o.stamp_ns < last_odometry || o.stamp_ns < 0) {
        if (!options.skip_going_backwards) {
          if (o.stamp_ns < 0) f.fail("field 'ipc_timestamp' = " + std::to_string(static_cast<double>(o.stamp_ns) * 1e-9) + " s is negative");
          backwards(f, o.stamp_ns, last_odometry, last_odometry_line);
        }
        ++log.odometry_going_backwards;
        continue;
      }
      last_odometry = o.stamp_ns;
      last_odometry_line = line;
      log.odometry.push_back(o);
    } else {
      ++log.skipped[escaped(type, 32)];
    }
  }
  if (in.bad()) throw LogError(escaped(name) + ": read error after line " + std::to_string(line));
  return log;
}

CarmenLog read_carmen_log(const std::filesystem::path& file, const CarmenReadOptions& options) {
  const std::string name = file.string();
  gzFile gz = gzopen(name.c_str(), "rb");
  if (!gz) throw LogError(escaped(name) + ": cannot be opened");
  std::string content;
  char buffer[1 << 16];
  for (;;) {
    const int n = gzread(gz, buffer, sizeof buffer);
    if (n < 0) {
      int code = 0;
      const std::string message = gzerror(gz, &code);
      gzclose(gz);
      throw LogError(escaped(name) + ": cannot be read (" + escaped(message) + ")");
    }
    if (n == 0) break;
    content.append(buffer, static_cast<size_t>(n));
  }
  int code = Z_OK;
  const std::string message = gzerror(gz, &code);
  gzclose(gz);
  if (code != Z_OK && code != Z_STREAM_END) throw LogError(escaped(name) + ": cannot be read (" + escaped(message) + ")");
  std::istringstream in(content);
  return parse_carmen_log(in, file.filename().string(), options);
}

}  // namespace locd::logs
