// Many servers, one fleet, over real DDS between hosts (domains 150, 151, 229): four network
// namespaces joined by veth pairs and a bridge (tests/common/hosts.sh, made and removed here;
// root): three locd servers, and 30 robots of `locsim fleet` on the fourth host. Every robot is
// served by exactly one server, the robots spread over the three, and when one server is killed
// (kill -9), or its cable is cut and comes back 5 s later, or it is stopped for 3 s (SIGSTOP) and
// resumes, the other two take its robots over from where they were: no robot ends without poses,
// no robot got two poses for one stamp (counted: zero), none is left on (or goes back to)
// server2.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "test_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using locd::test::ChildProcess;

enum class Fault { kKill, kCutAndHeal, kStall };
constexpr int kServers = 3;
constexpr int kRobots = 30;

std::string text_of(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The hosts of one test: made on construction, removed on destruction.
class Hosts {
 public:
  Hosts(int count, fs::path dir) : count_(count), dir_(std::move(dir)) {
    prefix_ = "lf" + std::to_string(::getpid() % 100000);
    script_ = locd::test::source_dir() + "/tests/common/hosts.sh";
    ok_ = run("up " + prefix_ + " " + std::to_string(count_) + " " + dir_.string()) == 0;
  }
  ~Hosts() { run("down " + prefix_ + " " + std::to_string(count_)); }
  bool ok() const { return ok_; }
  std::string ns(int i) const { return prefix_ + std::to_string(i); }
  std::string config(int i) const { return "file://" + (dir_ / ("host" + std::to_string(i) + ".xml")).string(); }
  // A program of this build run on host i.
  std::unique_ptr<ChildProcess> start(int i, const std::string& program, std::vector<std::string> args,
                                      const fs::path& log) const {
    std::vector<std::string> all = {"netns", "exec", ns(i), "env", "CYCLONEDDS_URI=" + config(i), program};
    all.insert(all.end(), args.begin(), args.end());
    return std::make_unique<ChildProcess>("/usr/sbin/ip", all, log.string());
  }

 private:
  friend class FleetHosts;
  int run(const std::string& args) const { return std::system((script_ + " " + args + " > /dev/null 2>&1").c_str()); }
  int count_;
  fs::path dir_;
  std::string prefix_, script_;
  bool ok_ = false;
};

class FleetHosts : public ::testing::TestWithParam<Fault> {
 protected:
  static int cut(const Hosts& hosts, int host, bool heal) {
    return hosts.run(std::string(heal ? "heal " : "cut ") + hosts.prefix_ + " " + std::to_string(host));
  }
};

TEST_P(FleetHosts, EachRobotHasOneServerAndAFailedServersRobotsAreTakenOver) {
  const int kDomain = GetParam() == Fault::kKill ? 150 : GetParam() == Fault::kCutAndHeal ? 151 : 229;
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to make network namespaces (CI runs as root)";
  const fs::path dir = fs::temp_directory_path() / ("locd_fleet_hosts_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Hosts hosts(1 + kServers, dir);
  ASSERT_TRUE(hosts.ok()) << "could not make the network namespaces";
  const std::string bin = locd::test::binary_dir() + "/bin/";

  std::vector<std::unique_ptr<ChildProcess>> servers;
  for (int s = 1; s <= kServers; ++s) {
    const fs::path config = dir / ("locd" + std::to_string(s) + ".yaml");
    std::ofstream(config) << "server_id: server" << s << "\n"
                          << "domain_id: " << kDomain << "\n"
                          << "plugin_directories: [" << locd::test::plugin_dir() << "]\n"
                          << "map_directories: [" << locd::test::source_dir() << "/config/maps]\n"
                          << "status_period_s: 0.2\n"
                          << "plugin_workers: {sessions_per_worker: 16}\n";
    servers.push_back(hosts.start(s, bin + "locd", {"--config", config.string()}, dir / ("locd" + std::to_string(s) + ".log")));
  }
  // Every server sees the other two before the robots ask.
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  for (int s = 0; s < kServers; ++s) {
    const fs::path log = dir / ("locd" + std::to_string(s + 1) + ".log");
    while (true) {
      const std::string text = text_of(log);
      size_t joined = 0;
      for (size_t at = text.find("joined the fleet"); at != std::string::npos; at = text.find("joined the fleet", at + 1)) {
        ++joined;
      }
      if (joined >= kServers - 1) break;
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "server" << s + 1 << " did not see the others:\n" << text;
      std::this_thread::sleep_for(50ms);
    }
  }

  const fs::path fleet_out = dir / "fleet.json";
  auto fleet = hosts.start(0, bin + "locsim",
                           {"fleet", locd::test::source_dir() + "/config/scenarios/corridor_fleet.yaml", "--robots",
                            std::to_string(kRobots), "--duration", GetParam() == Fault::kCutAndHeal ? "20" : "14", "--domain", std::to_string(kDomain), "--json"},
                           fleet_out);
  // Running: the fleet prints its line; then who serves whom, as an operator sees it.
  while (text_of(fleet_out).find("robots running") == std::string::npos) {
    ASSERT_TRUE(fleet->running()) << text_of(fleet_out);
    ASSERT_LT(std::chrono::steady_clock::now(), deadline + 30s) << text_of(fleet_out);
    std::this_thread::sleep_for(50ms);
  }
  std::this_thread::sleep_for(2s);
  const fs::path status_out = dir / "status.json";
  auto status = hosts.start(0, bin + "locctl", {"status", "--domain", std::to_string(kDomain), "--json"}, status_out);
  ASSERT_EQ(status->wait(30s), 0) << text_of(status_out);
  const auto before = nlohmann::json::parse(text_of(status_out));
  std::map<std::string, int> spread;
  for (const auto& session : before["sessions"]) ++spread[session["server"].get<std::string>()];
  EXPECT_EQ(spread.size(), static_cast<size_t>(kServers)) << before.dump();
  int total = 0;
  for (const auto& [server, count] : spread) total += count;
  EXPECT_EQ(total, kRobots) << before.dump();

  if (GetParam() == Fault::kKill) {
    servers[1]->signal(SIGKILL);
    servers[1]->wait(10s);
  } else if (GetParam() == Fault::kCutAndHeal) {
    // server2's cable is cut, and comes back: it must take no robot (it hears none while cut,
    // and sees the other servers again before it could), and give back the ones it served.
    ASSERT_EQ(cut(hosts, 2, false), 0);
    std::this_thread::sleep_for(5s);
    ASSERT_EQ(cut(hosts, 2, true), 0);
  } else {
    // server2 stalls: the others take its robots over; resumed, it still holds the stall's
    // messages, and must neither reach the robots with them nor keep the robots.
    servers[1]->signal(SIGSTOP);
    std::this_thread::sleep_for(3s);
    servers[1]->signal(SIGCONT);
  }
  ASSERT_EQ(fleet->wait(90s), 0) << text_of(fleet_out);
  const std::string out = text_of(fleet_out);
  const auto result = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(result["sessions_running"], kRobots) << result.dump(2);
  EXPECT_EQ(result["robots_silent_at_end"], 0) << result.dump(2);
  // Exactly one server at a time: no robot got two poses for one stamp.
  EXPECT_EQ(result["poses_duplicated"], 0) << result.dump(2);
  EXPECT_LE(result["poses_received"].get<size_t>(), result["poses_expected"].get<size_t>()) << result.dump(2);
  EXPECT_FALSE(result["robots_by_server"].contains("server2")) << result.dump(2);
  std::cout << "fleet: " << result.dump() << "\n";
  for (auto& s : servers) {
    if (s->running()) {
      s->signal(SIGTERM);
      EXPECT_EQ(s->wait(10s), 0);
    }
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Faults, FleetHosts, ::testing::Values(Fault::kKill, Fault::kCutAndHeal, Fault::kStall),
                         [](const auto& info) {
                           return info.param == Fault::kKill ? "kill" : info.param == Fault::kCutAndHeal ? "cut_and_heal" : "stall";
                         });

}  // namespace
