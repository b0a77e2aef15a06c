// The server's plugin index: every plugin file is inspected by a sandboxed locd-worker, never
// loaded into the server (here: the test process). Broken files are refused naming file and
// cause; the inspector's output is parsed as untrusted text; a malicious plugin's static
// constructor runs in the inspector, confined: it cannot read the key file, open a socket, see
// the server's DDS identity or secrets, or forge a log line.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "locd/server/plugin_index.hpp"
#include "test_env.hpp"
#include "test_plugin_index.hpp"

namespace {

namespace fs = std::filesystem;
using namespace locd;
using namespace locd::server;

const fs::path kDir = LOCD_BROKEN_PLUGIN_DIR;
std::string file_of(const std::string& name) { return (kDir / ("liblocd_" + name + ".so")).string(); }

std::string refusal(const PluginIndex& index, const std::string& name) {
  for (const auto& r : index.rejected()) {
    if (r.rfind(file_of(name) + ":", 0) == 0) return r;
  }
  return "";
}

TEST(PluginIndex, InspectsEachFileInAWorkerAndRefusesBrokenOnesNamingFileAndCause) {
  const PluginIndex index = locd::server::test::plugin_index(kDir.string());
  const std::vector<std::string> expected{"broken_configure_throws", "broken_factory_throws", "faulty", "fixture_odometry"};
  EXPECT_EQ(index.names(), expected);
  ASSERT_NE(index.find("fixture_odometry"), nullptr);
  EXPECT_EQ(index.find("fixture_odometry")->version, "0.1.0");
  EXPECT_EQ(index.find("fixture_odometry")->file, fs::path(file_of("fixture_odometry")));
  EXPECT_NE(refusal(index, "broken_no_entry").find("no entry point 'locd_plugin_descriptor'"), std::string::npos);
  EXPECT_NE(refusal(index, "broken_abi_version").find("ABI version 999"), std::string::npos);
  EXPECT_NE(refusal(index, "broken_invalid_name").find("invalid plugin name '../Evil.so'"), std::string::npos);
  EXPECT_NE(refusal(index, "broken_needs_input").find("needs inputs this server cannot give"), std::string::npos);
  EXPECT_EQ(index.rejected().size(), 4u);
  EXPECT_THROW(index.require("no_such_plugin"), ConfigError);
}

TEST(PluginIndex, InspectionOutputIsCheckedLikeTextFromOutside) {
  const fs::path file = "/plugins/libx.so";
  const std::string good = "locd-plugin-inspection 1\nname x\nversion 1\ndescription d\nconsumes 1\n";
  EXPECT_EQ(parse_inspection(good, file).name, "x");
  auto error_of = [&](const std::string& output) {
    try {
      parse_inspection(output, file);
    } catch (const PluginLoadError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error_of("name x\n").find("does not start with"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname ../X\nversion 1\nconsumes 1\n").find("invalid plugin name"), std::string::npos);
  EXPECT_NE(error_of(good + "name y\n").find("twice"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname x\nversion 1\nconsumes 1").find("without a newline"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname x\nversion \x1b[2J\nconsumes 1\n").find("not printable"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname x\nversion 1\nconsumes -1\n").find("32-bit decimal"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname x\nversion 1\nconsumes 0\n").find("consumes no"), std::string::npos);
  EXPECT_NE(error_of(std::string(kMaxInspectionBytes + 1, 'a')).find("more than"), std::string::npos);
  EXPECT_NE(error_of("locd-plugin-inspection 1\nname x\nversion " + std::string(100, 'v') + "\nconsumes 1\n").find("longer"),
            std::string::npos);
}

// What the test process writes to stderr (the logger's lines) while `run` runs.
template <class Run>
std::string stderr_of(Run run) {
  const fs::path capture = fs::temp_directory_path() / ("plugin_index_test_" + std::to_string(getpid()) + ".log");
  std::fflush(stderr);
  const int saved = dup(2);
  const int file = open(capture.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  dup2(file, 2);
  close(file);
  run();
  std::fflush(stderr);
  dup2(saved, 2);
  close(saved);
  std::ifstream in(capture);
  std::stringstream text;
  text << in.rdbuf();
  fs::remove(capture);
  return text.str();
}

TEST(PluginIndex, AMaliciousPluginsStaticConstructorRunsConfinedInTheInspector) {
  // The server's key file, its identity and a secret in its environment, and a TCP listener.
  const fs::path key = LOCD_MALICIOUS_SECRET_FILE;
  fs::create_directories(key.parent_path());
  std::ofstream(key) << "KEY-MARKER-7f3a\n";
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  setenv("LOCD_IDENTITY", key.parent_path().c_str(), 1);
  setenv("CYCLONEDDS_URI", "file:///secure.xml", 1);
  setenv("LOCD_TEST_SECRET", "ENV-MARKER-91c2", 1);
  const int listener = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
  int one = 1;
  setsockopt(listener, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(47231);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address), 0) << std::strerror(errno);
  ASSERT_EQ(listen(listener, 4), 0);
  // The key is readable to this process: the test would prove nothing otherwise.
  ASSERT_NE(locd::test::read_text(key).find("KEY-MARKER"), std::string::npos);

  PluginIndex index;
  const std::string log = stderr_of([&] { index = locd::server::test::plugin_index(LOCD_MALICIOUS_PLUGIN_DIR); });
  unsetenv("LOCD_IDENTITY");
  unsetenv("CYCLONEDDS_URI");
  unsetenv("LOCD_TEST_SECRET");

  // Served as any plugin; its constructor ran in another process, confined.
  EXPECT_NE(index.find("malicious"), nullptr) << log;
  EXPECT_NE(log.find("malicious: constructor in pid "), std::string::npos) << log;
  EXPECT_EQ(log.find("malicious: constructor in pid " + std::to_string(getpid()) + "\\\""), std::string::npos) << log;
  EXPECT_EQ(log.find("KEY-MARKER"), std::string::npos) << log;
  EXPECT_EQ(log.find("READ "), std::string::npos) << log;
  EXPECT_NE(log.find("open " + key.string() + ": Permission denied"), std::string::npos) << log;
  EXPECT_NE(log.find("socket(AF_INET): Operation not permitted"), std::string::npos) << log;
  EXPECT_NE(log.find("socket(AF_UNIX): Operation not permitted"), std::string::npos) << log;
  EXPECT_EQ(log.find("CONNECTED"), std::string::npos) << log;
  EXPECT_EQ(accept(listener, nullptr, nullptr), -1);
  close(listener);
  EXPECT_EQ(log.find("LEAKED"), std::string::npos) << log;
  EXPECT_EQ(log.find("ENV-MARKER"), std::string::npos) << log;
  EXPECT_NE(log.find("env CYCLONEDDS_URI unset"), std::string::npos) << log;
  // The forged lines are there, twice, each quoted inside a line of the server's naming the inspector.
  std::istringstream lines(log);
  int forged = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.find("FORGED-LOG-LINE") == std::string::npos) continue;
    ++forged;
    EXPECT_EQ(line.rfind("2026-01-01T00:00:00.000Z", 0), std::string::npos) << line;
    EXPECT_NE(line.find("(pid "), std::string::npos) << line;
    EXPECT_NE(line.find("wrote to stderr: \"2026-01-01T00:00:00.000Z error [robot_a] FORGED-LOG-LINE"), std::string::npos) << line;
  }
  EXPECT_EQ(forged, 2) << log;
  std::cout << log;  // what the plugin tried, as the server logged it
}

TEST(StderrLines, LinesAreEscapedCutAndRateLimited) {
  Logger logger(LogLevel::kWarning);
  std::string log = stderr_of([&] {
    StderrLines lines("plugin 'x' (worker pid 1)", logger);
    const std::string flood(200 * 3, '\n');
    lines.append("a\x1b[31mred\r\n", 11);
    lines.append(flood.data(), flood.size());
    lines.append(std::string(2000, 'z').data(), 2000);
    lines.finish();
    EXPECT_EQ(lines.logged(), static_cast<size_t>(StderrLines::kBurstLines));
    EXPECT_GT(lines.suppressed_total(), 500u);
  });
  EXPECT_NE(log.find("wrote to stderr: \"a\\x1b[31mred\\r\""), std::string::npos) << log.substr(0, 400);
  EXPECT_NE(log.find("line(s) of stderr not logged (rate limit)"), std::string::npos);
}

}  // namespace
