// DDS Security and session ownership over real Cyclone DDS on loopback. Every participant is a
// child process with its own CYCLONEDDS_URI, since Cyclone holds one identity per process: locd
// (server identity), locsim live (the robot corridor_bot), locctl (operators, monitors, robots)
// and security_peer (an intruder that keeps writing whether or not anyone listens). The
// certificates are made by `locctl security` in the test; the attacks by hand with openssl.
// Domains 120-139.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "test_env.hpp"
#include "test_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::test::ChildProcess;
using locd::test::TestServer;

constexpr int kDomainAttacks = 120;
constexpr int kDomainBadCredentials = 121;
constexpr int kDomainOwnership = 122;
constexpr int kDomainSquatters = 123;
constexpr int kDomainEncryptedRtps = 210;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "'" << (part) << "' not in:\n" << (text)

std::string program(const std::string& name) {
  if (name == "security_peer") return locd::test::binary_dir() + "/tests/security_peer";
  return locd::test::binary_dir() + "/bin/" + name;
}

std::string loopback() { return "file://" + locd::test::source_dir() + "/config/dds/loopback.xml"; }

// The environment of a process acting as the identity in `folder` (plain DDS when empty).
std::vector<std::string> as(const fs::path& folder) {
  if (folder.empty()) return {"CYCLONEDDS_URI=" + loopback()};
  return {"CYCLONEDDS_URI=" + loopback() + ",file://" + (folder / "cyclonedds.xml").string()};
}

struct Outcome {
  int code;
  std::string output;
};

int run_counter = 0;

// Runs a program to its end.
Outcome run(const fs::path& scratch, const std::string& name, const std::vector<std::string>& args,
        const std::vector<std::string>& environment, std::chrono::seconds timeout = 60s) {
  ChildProcess child(program(name), args, (scratch / (name + std::to_string(++run_counter) + ".log")).string(),
                     environment);
  const int code = child.wait(timeout);
  return {code, child.output()};
}

std::string read(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void write(const fs::path& file, const std::string& text) { std::ofstream(file) << text; }

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

std::string utc(long long seconds) {
  const std::time_t t = static_cast<std::time_t>(seconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}
long long now() { return static_cast<long long>(std::time(nullptr)); }
constexpr long long kDay = 86400;

// A scratch folder, kept when the test failed.
class Scratch {
 public:
  explicit Scratch(const std::string& name)
      : path_(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Scratch() {
    std::error_code ec;
    if (!::testing::Test::HasFailure()) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// `locctl security ...`, which must succeed.
fs::path locctl_security(const fs::path& scratch, const std::vector<std::string>& args) {
  std::vector<std::string> all = {"security"};
  all.insert(all.end(), args.begin(), args.end());
  const Outcome r = run(scratch, "locctl", all, {});
  EXPECT_EQ(r.code, 0) << r.output;
  return args.size() >= 3 ? fs::path(args[1]) / args[0] / args[2] : fs::path(args[1]);
}

// An identity folder's copy whose Cyclone config points at the copy (to tamper with it).
fs::path copy_identity(const fs::path& from, const fs::path& to) {
  fs::copy(from, to, fs::copy_options::recursive);
  write(to / "cyclonedds.xml", replaced(read(to / "cyclonedds.xml"), from.string() + "/", to.string() + "/"));
  return to;
}

// The intruder: `security_peer DOMAIN PARTITION_ROBOT SAMPLE_ROBOT ACTION SECONDS` as `identity`.
Outcome intrude(const fs::path& scratch, const fs::path& identity, int domain, const std::string& partition_robot,
            const std::string& sample_robot, const std::string& action, const std::vector<std::string>& prefix = {},
            const std::string& seconds = "3") {
  std::vector<std::string> args = {std::to_string(domain), partition_robot, sample_robot, action, seconds};
  if (prefix.empty()) return run(scratch, "security_peer", args, as(identity));
  // faketime -f OFFSET security_peer ARGS: the peer's clock is off, the server's is not.
  std::vector<std::string> faked = prefix;
  faked.push_back(program("security_peer"));
  faked.insert(faked.end(), args.begin(), args.end());
  std::vector<std::string> environment = as(identity);
  environment.push_back("FAKETIME_DONT_FAKE_MONOTONIC=1");
  ChildProcess child("/usr/bin/faketime", faked, (scratch / ("faketime" + std::to_string(++run_counter) + ".log")).string(),
                     environment);
  const int code = child.wait(60s);
  return {code, child.output()};
}

double largest_error(const std::string& locsim_output) {
  double largest = 0.0;
  const std::regex error_re("error=([0-9.]+)m");
  for (auto it = std::sregex_iterator(locsim_output.begin(), locsim_output.end(), error_re);
       it != std::sregex_iterator(); ++it) {
    largest = std::max(largest, std::stod((*it)[1]));
  }
  return largest;
}

// Robot corridor_bot localizes (locsim live, its own identity) while intruders try to move, stop
// and feed it; none gets through and its estimate stays where it is. The legitimate paths work:
// the robot itself, an operator steering, a monitor watching.
TEST(Security, IntrudersAreRefusedAndTheRobotIsUnaffectedWhileLegitimateRolesWork) {
  Scratch scratch("locd_security_attacks");
  const fs::path fleet = scratch.path() / "fleet";
  const fs::path other = scratch.path() / "other_fleet";
  locctl_security(scratch.path(), {"init", fleet.string()});
  const fs::path server_id = locctl_security(scratch.path(), {"server", fleet.string(), "srv"});
  const fs::path robot = locctl_security(scratch.path(), {"robot", fleet.string(), "corridor_bot"});
  const fs::path robot2 = locctl_security(scratch.path(), {"robot", fleet.string(), "r2"});
  const fs::path operator_id = locctl_security(scratch.path(), {"operator", fleet.string(), "alice"});
  const fs::path monitor = locctl_security(scratch.path(), {"monitor", fleet.string(), "wall"});
  // Another CA's robot of the same name.
  locctl_security(scratch.path(), {"init", other.string()});
  const fs::path stranger = locctl_security(scratch.path(), {"robot", other.string(), "corridor_bot"});
  // r2 with permissions granting every robot's partition: edited after signing (tampered), or
  // re-signed by the other CA together with a governance of its own (forged).
  const fs::path tampered = copy_identity(robot2, scratch.path() / "tampered");
  write(tampered / "permissions.p7s", replaced(read(tampered / "permissions.p7s"), ">robot.r2<", ">robot.*<"));
  const fs::path forged = copy_identity(robot2, scratch.path() / "forged");
  write(forged / "permissions.xml", replaced(read(forged / "permissions.xml"), ">robot.r2<", ">robot.*<"));
  for (const auto& [document, out] : {std::pair{forged / "permissions.xml", forged / "permissions.p7s"},
                                      std::pair{fleet / "governance.xml", forged / "governance.p7s"}}) {
    ASSERT_EQ(std::system(("openssl smime -sign -text -in " + document.string() + " -signer " +
                           (other / "ca" / "ca.pem").string() + " -inkey " + (other / "ca" / "ca.key").string() +
                           " -out " + out.string())
                              .c_str()),
              0);
  }
  write(forged / "cyclonedds.xml", replaced(read(forged / "cyclonedds.xml"), "<PermissionsCA>file://" + forged.string() +
                                                                                  "/ca.pem",
                                            "<PermissionsCA>file://" + (other / "ca" / "ca.pem").string()));

  locd::test::TestServerOptions options;
  options.environment = as(server_id);
  TestServer server("security_attacks", kDomainAttacks, options);
  const std::string domain = std::to_string(kDomainAttacks);
  ChildProcess locsim(program("locsim"),
                      {"live", locd::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain", domain,
                       "--duration", "20", "--json", "--server-timeout", "30"},
                      (scratch.path() / "locsim.log").string(), as(robot));
  // Until the robot localizes.
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (locsim.output().find("t=2.0s") == std::string::npos) {
    ASSERT_TRUE(locsim.running()) << locsim.output() << "\nserver:\n" << server.process().output();
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << locsim.output();
    std::this_thread::sleep_for(100ms);
  }

  // Every intruder at once, while the robot drives, and an operator and a monitor reading. Each
  // entry: who, identity, partition robot, sample robot, action, expected exit code and output.
  struct Attempt {
    std::string who;
    fs::path identity;
    std::string partition_robot, action;
    int code;
    std::string expected;
  };
  const std::vector<Attempt> attempts = {
      // Participants the server never admits: their writers match no reader.
      {"no certificate", {}, "corridor_bot", "initial-pose", 0, "matched 0"},
      {"another CA's corridor_bot", stranger, "corridor_bot", "initial-pose", 0, "matched 0"},
      {"r2 with forged permissions", forged, "corridor_bot", "initial-pose", 0, "matched 0"},
      // Permissions whose signature no longer holds: refused by the intruder's own DDS.
      {"r2 with tampered permissions", tampered, "corridor_bot", "stop", 4, "validating local permissions"},
      // Robot r2 and a monitor in corridor_bot's partition: their own DDS refuses the writer.
      {"r2", robot2, "corridor_bot", "initial-pose", 3, "not allowed by DDS Security"},
      {"r2", robot2, "corridor_bot", "stop", 3, "not allowed by DDS Security"},
      {"r2", robot2, "corridor_bot", "odometry", 3, "not allowed by DDS Security"},
      {"monitor", monitor, "corridor_bot", "stop", 3, "not allowed by DDS Security"},
      {"monitor", monitor, "corridor_bot", "initial-pose", 3, "not allowed by DDS Security"},
      // r2 in its own partition, naming corridor_bot: the server reads it and refuses it.
      {"r2 in robot.r2", robot2, "r2", "initial-pose", 0, "matched 1"},
      {"r2 in robot.r2", robot2, "r2", "stop", 0, "matched 1"},
      {"r2 in robot.r2", robot2, "r2", "odometry", 0, "matched 1"},
  };
  std::vector<std::unique_ptr<ChildProcess>> intruders;
  for (const auto& a : attempts) {
    intruders.push_back(std::make_unique<ChildProcess>(
        program("security_peer"), std::vector<std::string>{domain, a.partition_robot, "corridor_bot", a.action, "4"},
        (scratch.path() / ("intruder" + std::to_string(intruders.size()) + ".log")).string(), as(a.identity)));
  }
  // What a robot may not read: every robot's status, another robot's poses.
  const Outcome peek = run(scratch.path(), "locctl", {"status", "--domain", domain}, as(robot2));
  EXPECT_EQ(peek.code, 1) << peek.output;
  EXPECT_CONTAINS(peek.output, "create reader on locd/pose in partition [robot.*]: not allowed by DDS Security");
  // The legitimate roles: an operator and a monitor read the robot's session and poses.
  const Outcome watch = run(scratch.path(), "locctl", {"watch", "corridor_bot", "--count", "3", "--timeout", "20",
                                                       "--domain", domain}, as(monitor));
  EXPECT_EQ(watch.code, 0) << watch.output;
  for (size_t i = 0; i < attempts.size(); ++i) {
    const auto& a = attempts[i];
    EXPECT_EQ(intruders[i]->wait(60s), a.code) << a.who << " " << a.action << ": " << intruders[i]->output();
    EXPECT_CONTAINS(intruders[i]->output(), a.expected) << a.who << " " << a.action;
  }
  ASSERT_TRUE(locsim.running()) << "the robot's run ended before the intruders were done:\n" << locsim.output();
  const Outcome status = run(scratch.path(), "locctl", {"status", "corridor_bot", "--json", "--domain", domain},
                             as(operator_id));
  EXPECT_EQ(status.code, 0) << status.output;
  EXPECT_CONTAINS(status.output, "\"state\":\"running\"");
  EXPECT_CONTAINS(status.output, "\"rejected\":0");

  const int code = locsim.wait(120s);
  const std::string output = locsim.output();
  ASSERT_EQ(code, 0) << output << "\nserver:\n" << server.process().output();
  // The intruders moved the robot 29-37 m off; here it never leaves its track.
  EXPECT_LT(largest_error(output), 0.5) << output;
  EXPECT_NE(output.find("\"converged\":true"), std::string::npos) << output;

  // An operator steers any robot: starts and stops r2's session.
  const Outcome use = run(scratch.path(), "locctl",
                      {"use", "r2", locd::test::source_dir() + "/config/plugins/feature_ekf.yaml", "--domain", domain},
                      as(operator_id));
  EXPECT_EQ(use.code, 0) << use.output;
  const Outcome stop = run(scratch.path(), "locctl", {"stop", "r2", "--domain", domain}, as(operator_id));
  EXPECT_EQ(stop.code, 0) << stop.output;

  const std::string log = server.process().output();
  // What reached the server was refused, named by robot and partition; the stranger's handshake
  // was refused naming its certificate and the cause.
  EXPECT_CONTAINS(log, "a sample for robot 'corridor_bot' was published in partition [robot.r2]");
  EXPECT_CONTAINS(log, "[dds] Begin handshake reply failed: Certificate not valid: error: unable to get local issuer "
                       "certificate; subject: /O=locd/OU=robot/CN=corridor_bot");
  EXPECT_EQ(log.find("stopped by request 777"), std::string::npos) << log;
}

// A fleet whose governance also protects whole RTPS messages (`--rtps-protection encrypt`, what
// SROS2 asks): the robot localizes as in a fleet without it, and a participant without a
// certificate matches nothing.
TEST(Security, AFleetWithEncryptedRtpsMessagesLocalizes) {
  Scratch scratch("locd_security_rtps");
  const fs::path fleet = scratch.path() / "fleet";
  locctl_security(scratch.path(), {"init", fleet.string(), "--rtps-protection", "encrypt"});
  EXPECT_CONTAINS(read(fleet / "governance.xml"), "<rtps_protection_kind>ENCRYPT</rtps_protection_kind>");
  const fs::path server_id = locctl_security(scratch.path(), {"server", fleet.string(), "srv"});
  const fs::path robot = locctl_security(scratch.path(), {"robot", fleet.string(), "corridor_bot"});
  locd::test::TestServerOptions options;
  options.environment = as(server_id);
  TestServer server("security_rtps", kDomainEncryptedRtps, options);
  const std::string domain = std::to_string(kDomainEncryptedRtps);
  ChildProcess locsim(program("locsim"),
                      {"live", locd::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain", domain,
                       "--duration", "10", "--json", "--server-timeout", "30"},
                      (scratch.path() / "locsim.log").string(), as(robot));
  const Outcome stranger = intrude(scratch.path(), {}, kDomainEncryptedRtps, "corridor_bot", "corridor_bot", "initial-pose");
  EXPECT_EQ(stranger.code, 0) << stranger.output;
  EXPECT_CONTAINS(stranger.output, "matched 0");
  const int code = locsim.wait(120s);
  const std::string output = locsim.output();
  ASSERT_EQ(code, 0) << output << "\nserver:\n" << server.process().output();
  EXPECT_LT(largest_error(output), 0.5) << output;
  EXPECT_NE(output.find("\"converged\":true"), std::string::npos) << output;
}

// Waits until locd's log holds `text`.
::testing::AssertionResult log_shows(ChildProcess& locd, const std::string& text, std::chrono::seconds timeout = 30s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (locd.output().find(text) == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline || !locd.running()) {
      return ::testing::AssertionFailure() << "'" << text << "' not in locd's log:\n" << locd.output();
    }
    std::this_thread::sleep_for(50ms);
  }
  return ::testing::AssertionSuccess();
}

// Expired, not yet valid and revoked certificates, and permissions whose validity ended: the
// identity's own participant refuses to start, naming the subject and the cause; a peer whose
// clock is off (or that leaves out the CRL) gets as far as the server, which refuses it and logs
// the subject and the cause.
TEST(Security, BadCredentialsAreRefusedNamingTheIdentityAndTheCause) {
  Scratch scratch("locd_security_credentials");
  const fs::path fleet = scratch.path() / "fleet";
  // A CA from ten days ago, so identities can be made valid in the past.
  locctl_security(scratch.path(), {"init", fleet.string(), "--start", utc(now() - 10 * kDay)});
  // The server's identity must look valid to peers whose clocks run days off.
  const fs::path server_id = locctl_security(
      scratch.path(), {"server", fleet.string(), "srv", "--start", utc(now() - 5 * kDay), "--days", "30"});
  const fs::path expired = locctl_security(
      scratch.path(), {"robot", fleet.string(), "expired", "--start", utc(now() - 3 * kDay), "--days", "1"});
  const fs::path early = locctl_security(
      scratch.path(), {"robot", fleet.string(), "early", "--start", utc(now() + 2 * kDay), "--days", "1"});
  const fs::path revoked = locctl_security(scratch.path(), {"robot", fleet.string(), "revoked"});
  locctl_security(scratch.path(), {"revoke", fleet.string(), "robot", "revoked"});
  // A certificate valid for a month from five days ago, with permissions that lapsed yesterday.
  const fs::path lapsed = locctl_security(
      scratch.path(), {"robot", fleet.string(), "lapsed", "--start", utc(now() - 5 * kDay), "--days", "30"});
  const std::string permissions = read(lapsed / "permissions.xml");
  const std::regex validity("<not_before>[^<]*</not_before><not_after>[^<]*</not_after>");
  write(lapsed / "permissions.xml",
        std::regex_replace(permissions, validity, "<not_before>" + utc(now() - 3 * kDay) + "</not_before><not_after>" +
                                                      utc(now() - kDay) + "</not_after>"));
  ASSERT_EQ(std::system(("openssl smime -sign -text -in " + (lapsed / "permissions.xml").string() + " -signer " +
                         (fleet / "ca" / "ca.pem").string() + " -inkey " + (fleet / "ca" / "ca.key").string() +
                         " -out " + (lapsed / "permissions.p7s").string())
                            .c_str()),
            0);

  // Their own DDS refuses them.
  const std::vector<std::tuple<fs::path, std::string, std::string>> cases = {
      {expired, "CN=expired", "certificate has expired"},
      {early, "CN=early", "certificate is not yet valid"},
      {revoked, "CN=revoked", "certificate revoked"},
      {lapsed, "CN=lapsed", "Permissions validity period expired"}};
  for (const auto& [identity, subject, cause] : cases) {
    const Outcome r = intrude(scratch.path(), identity, kDomainBadCredentials, identity.filename(),
                          identity.filename(), "odometry");
    EXPECT_EQ(r.code, 4) << r.output;
    EXPECT_CONTAINS(r.output, subject);
    EXPECT_CONTAINS(r.output, cause);
  }

  // The server refuses them when their own clock (faketime) or config (no CRL) lets them try.
  locd::test::TestServerOptions options;
  options.environment = as(server_id);
  TestServer server("security_credentials", kDomainBadCredentials, options);
  for (const fs::path& identity : {expired, early, revoked, lapsed}) {
    write(identity / "cyclonedds.xml",
          std::regex_replace(read(identity / "cyclonedds.xml"), std::regex("\\s*<CRL>[^<]*</CRL>"), ""));
  }
  const std::string domain = std::to_string(kDomainBadCredentials);
  EXPECT_CONTAINS(intrude(scratch.path(), expired, kDomainBadCredentials, "expired", "expired", "odometry",
                          {"-f", "-60h"}).output, "matched 0");
  EXPECT_CONTAINS(intrude(scratch.path(), early, kDomainBadCredentials, "early", "early", "odometry",
                          {"-f", "+60h"}).output, "matched 0");
  EXPECT_CONTAINS(intrude(scratch.path(), revoked, kDomainBadCredentials, "revoked", "revoked", "odometry").output,
                  "matched 0");
  EXPECT_CONTAINS(intrude(scratch.path(), lapsed, kDomainBadCredentials, "lapsed", "lapsed", "odometry",
                          {"-f", "-2d"}).output, "matched 0");
  EXPECT_TRUE(log_shows(server.process(), "certificate has expired; subject: /O=locd/OU=robot/CN=expired"));
  EXPECT_TRUE(log_shows(server.process(), "certificate is not yet valid; subject: /O=locd/OU=robot/CN=early"));
  EXPECT_TRUE(log_shows(server.process(), "certificate revoked; subject: /O=locd/OU=robot/CN=revoked"));
  EXPECT_TRUE(log_shows(server.process(), "Permissions validity period expired for CN=lapsed,OU=robot,O=locd"));
}

// Sessions are owned (plain DDS): ids squatted by processes that went away free themselves after
// session_grace_s, so the real robot gets its session; a robot that keeps writing keeps its
// session; one that crashes loses it once its lease expires.
TEST(SessionOwnership, SquattedIdsFreeThemselvesAndALiveRobotKeepsItsSession) {
  Scratch scratch("locd_session_ownership");
  locd::test::TestServerOptions options;
  options.extra_config = "session_grace_s: 3\nmax_sessions: 2\n";
  TestServer server("ownership", kDomainOwnership, options);
  const std::string domain = std::to_string(kDomainOwnership);
  const std::string config = locd::test::source_dir() + "/config/plugins/feature_ekf.yaml";
  // Two processes take a session each and exit: the server is full.
  for (const char* squatter : {"squat1", "squat2"}) {
    const Outcome use = run(scratch.path(), "locctl", {"use", squatter, config, "--domain", domain}, as({}));
    ASSERT_EQ(use.code, 0) << use.output;
  }
  const Outcome locked_out = run(scratch.path(), "locctl", {"use", "corridor_bot", config, "--domain", domain}, as({}));
  EXPECT_EQ(locked_out.code, 1) << locked_out.output;
  EXPECT_CONTAINS(locked_out.output, "max_sessions = 2");
  // Their sessions end once no writer of theirs is left.
  for (const char* squatter : {"squat1", "squat2"}) {
    EXPECT_TRUE(log_shows(server.process(), std::string("session ended: no live writer of robot '") + squatter +
                                                "' (session requests, initial poses, map saves, sensor data) for 3 s"));
  }
  const Outcome ended = run(scratch.path(), "locctl", {"status", "squat1", "--json", "--domain", domain}, as({}));
  EXPECT_CONTAINS(ended.output, "\"state\":\"stopped\"");
  EXPECT_CONTAINS(ended.output, "session ended: no live writer of robot 'squat1'");

  // The real robot drives for longer than the grace period and keeps its session throughout.
  ChildProcess locsim(program("locsim"),
                      {"live", locd::test::source_dir() + "/config/scenarios/corridor.yaml", "--domain", domain,
                       "--duration", "8", "--json", "--server-timeout", "30"},
                      (scratch.path() / "locsim.log").string(), as({}));
  ASSERT_EQ(locsim.wait(90s), 0) << locsim.output() << "\nserver:\n" << server.process().output();
  EXPECT_NE(locsim.output().find("\"converged\":true"), std::string::npos) << locsim.output();
  EXPECT_EQ(server.process().output().find("no live writer of robot 'corridor_bot'"), std::string::npos);
  // Gone, it frees its id.
  EXPECT_TRUE(log_shows(server.process(), "session ended: no live writer of robot 'corridor_bot'"));

  // A robot that crashes: its writers die with it, noticed when its lease (1 s here) expires.
  const fs::path short_lease = scratch.path() / "short_lease.xml";
  write(short_lease, "<CycloneDDS><Domain id=\"any\"><Discovery><LeaseDuration>1s</LeaseDuration></Discovery>"
                     "</Domain></CycloneDDS>");
  std::vector<std::string> crashing = as({});
  crashing[0] += ",file://" + short_lease.string();
  ChildProcess robot(program("security_peer"), {domain, "crashbot", "crashbot", "odometry", "60"},
                     (scratch.path() / "crashbot.log").string(), crashing);
  const Outcome use = run(scratch.path(), "locctl", {"use", "crashbot", config, "--domain", domain}, as({}));
  ASSERT_EQ(use.code, 0) << use.output;
  std::this_thread::sleep_for(4s);  // longer than the grace period: the robot's odometry keeps it
  EXPECT_EQ(server.process().output().find("no live writer of robot 'crashbot'"), std::string::npos);
  robot.signal(SIGKILL);
  EXPECT_TRUE(log_shows(server.process(), "session ended: no live writer of robot 'crashbot'"));
}

}  // namespace
