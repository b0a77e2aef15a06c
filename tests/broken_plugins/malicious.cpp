// A malicious plugin for the sandbox tests (never installed). Its static constructor, which runs
// as soon as the file is loaded, and its update each try what a plugin must not manage, and write
// what happened to fd 2 (which locd captures, escapes and rate-limits):
//   - read the server's key file (LOCD_MALICIOUS_SECRET_FILE, a path the test makes, and
//     $LOCD_IDENTITY/key.pem), and print its first bytes;
//   - create a TCP socket and connect to 127.0.0.1:LOCD_MALICIOUS_PORT, and a Unix socket;
//   - read CYCLONEDDS_URI, LOCD_IDENTITY and LOCD_TEST_SECRET from its environment;
//   - forge a locd log line on fd 2 and through /proc/self/fd/2.
// Otherwise it is fixture_odometry's honest twin: the pose is the odometry pose.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "locd/sdk/plugin.hpp"

namespace {

void say(const std::string& text) {
  const std::string line = "malicious: " + text + "\n";
  [[maybe_unused]] const ssize_t n = ::write(2, line.data(), line.size());
}

std::string try_read(const std::string& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "open " + file + ": " + std::strerror(errno);
  char bytes[64] = {};
  const ssize_t n = ::read(fd, bytes, sizeof bytes - 1);
  ::close(fd);
  return "READ " + file + ": " + std::string(bytes, n > 0 ? static_cast<size_t>(n) : 0);
}

std::string try_connect() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket(AF_INET): ") + std::strerror(errno);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(LOCD_MALICIOUS_PORT);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  const std::string result = rc == 0 ? "CONNECTED to 127.0.0.1" : std::string("connect: ") + std::strerror(errno);
  ::close(fd);
  return result;
}

std::string try_unix_socket() {
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket(AF_UNIX): ") + std::strerror(errno);
  ::close(fd);
  return "MADE a Unix socket";
}

std::string environment(const char* name) {
  const char* value = std::getenv(name);
  return std::string("env ") + name + (value ? std::string(" LEAKED=") + value : " unset");
}

void attack(const std::string& where) {
  say(where + " in pid " + std::to_string(::getpid()));
  say(where + ": " + try_read(LOCD_MALICIOUS_SECRET_FILE));
  if (const char* identity = std::getenv("LOCD_IDENTITY")) say(where + ": " + try_read(std::string(identity) + "/key.pem"));
  say(where + ": " + try_connect());
  say(where + ": " + try_unix_socket());
  for (const char* name : {"CYCLONEDDS_URI", "LOCD_IDENTITY", "LOCD_TEST_SECRET"}) say(where + ": " + environment(name));
  const std::string forged = "2026-01-01T00:00:00.000Z error [robot_a] FORGED-LOG-LINE from " + where + "\n";
  [[maybe_unused]] ssize_t n = ::write(2, forged.data(), forged.size());
  const int proc = ::open("/proc/self/fd/2", O_WRONLY | O_CLOEXEC);
  if (proc >= 0) {
    n = ::write(proc, forged.data(), forged.size());
    ::close(proc);
  }
}

struct AtLoad {
  AtLoad() { attack("constructor"); }
} at_load;

class Malicious : public locd::Localizer {
 public:
  void configure(const locd::PluginContext&, const locd::Params& params) override { params.expect_only({}); }
  void set_pose(const locd::PoseEstimate&) override {}
  locd::UpdateResult update(const locd::Measurement& measurement) override {
    if (!attacked_) {
      attacked_ = true;
      attack("update");
    }
    const auto* odometry = std::get_if<locd::Odometry>(&measurement);
    if (!odometry) throw locd::InputError("malicious consumes odometry only");
    locd::UpdateResult result;
    locd::PoseEstimate estimate;
    estimate.header = {odometry->header.stamp_ns, "map"};
    estimate.pose = odometry->pose;
    estimate.covariance = locd::Matrix6d::Identity() * 0.01;
    result.estimate = estimate;
    return result;
  }

 private:
  bool attacked_ = false;
};

}  // namespace

LOCD_REGISTER_PLUGIN(Malicious, "malicious", "0.1.0", "test fixture: tries to escape its sandbox",
                     locd::kinds(locd::MeasurementKind::kOdometry))
