// locctl security's documents and command line (the openssl steps run in the integration tests,
// tests/integration/security_test.cpp): who may publish and read what in which partition, the
// governance, and the Cyclone config each identity folder gets, which must be the shipped
// template config/dds/secure.xml with the folder filled in.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "command_line.hpp"
#include "security.hpp"

namespace {

using namespace locd::locctl;
using namespace locd::locctl::security;

// The <publish> / <subscribe> blocks of a permissions document, as "kind topics|partition" lines.
std::vector<std::string> rules_of(const std::string& xml) {
  std::vector<std::string> rules;
  const std::regex block("<(publish|subscribe)>\\s*<topics>(.*?)</topics>\\s*(<partitions><partition>([^<]*)"
                         "</partition></partitions>)?\\s*</(publish|subscribe)>");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), block); it != std::sregex_iterator(); ++it) {
    std::string topics = std::regex_replace((*it)[2].str(), std::regex("</topic><topic>"), " ");
    topics = std::regex_replace(topics, std::regex("</?topic>"), "");
    rules.push_back((*it)[1].str() + " " + topics + "|" + (*it)[4].str());
  }
  return rules;
}

const Validity kValidity{parse_utc("2026-01-01T00:00:00Z"), 30};

TEST(LocctlSecurity, ARobotFeedsAndSteersOnlyItselfAndReadsOnlyItsOwnOutputs) {
  const std::string xml = permissions_xml(Role::kRobot, "r1", kValidity);
  EXPECT_NE(xml.find("<subject_name>CN=r1,OU=robot,O=locd</subject_name>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<not_before>2026-01-01T00:00:00Z</not_before><not_after>2026-01-31T00:00:00Z</not_after>"),
            std::string::npos) << xml;
  EXPECT_NE(xml.find("<default>DENY</default>"), std::string::npos);
  EXPECT_EQ(rules_of(xml),
            (std::vector<std::string>{
                "publish locd/odometry locd/imu locd/scan locd/cloud locd/image locd/detections locd/session_request "
                "locd/initial_pose locd/map_save_request locd/ground_truth|robot.r1",
                "subscribe locd/pose locd/grid locd/map_cloud locd/landmark_map locd/diagnostics locd/exploration_goal "
                "locd/session_status|robot.r1",
                "subscribe locd/server_info|"}));
}

TEST(LocctlSecurity, OperatorsSteerEveryRobotMonitorsOnlyReadServersServe) {
  const auto op = rules_of(permissions_xml(Role::kOperator, "alice", kValidity));
  ASSERT_EQ(op.size(), 3u);
  EXPECT_EQ(op[0], "publish locd/session_request locd/initial_pose locd/map_save_request|robot.*");
  EXPECT_EQ(op[1].substr(0, 10), "subscribe ");
  EXPECT_EQ(op[1].find("locd/scan"), std::string::npos) << "an operator reads outputs, not raw sensors";
  for (const auto& rule : rules_of(permissions_xml(Role::kMonitor, "wall", kValidity))) {
    EXPECT_EQ(rule.rfind("subscribe ", 0), 0u) << rule;
  }
  const auto server = rules_of(permissions_xml(Role::kServer, "srv", kValidity));
  ASSERT_EQ(server.size(), 4u);
  EXPECT_EQ(server[0].rfind("subscribe locd/odometry", 0), 0u) << server[0];
  EXPECT_NE(server[0].find("|robot.*"), std::string::npos);
  EXPECT_EQ(server[1].rfind("publish locd/pose", 0), 0u) << server[1];
  EXPECT_EQ(server[2], "publish locd/server_info locd/serving locd/resume_state|");
}

TEST(LocctlSecurity, GovernanceEncryptsAndAccessControlsEverything) {
  const std::string xml = governance_xml();
  for (const char* part : {"<allow_unauthenticated_participants>false<", "<enable_join_access_control>true<",
                           "<discovery_protection_kind>ENCRYPT<", "<liveliness_protection_kind>ENCRYPT<",
                           "<topic_expression>*</topic_expression>", "<enable_read_access_control>true<",
                           "<enable_write_access_control>true<", "<metadata_protection_kind>ENCRYPT<",
                           "<data_protection_kind>ENCRYPT<", "<max>230</max>"}) {
    EXPECT_NE(xml.find(part), std::string::npos) << part;
  }
}

TEST(LocctlSecurity, RtpsProtectionIsNoneUnlessAsked) {
  EXPECT_NE(governance_xml().find("<rtps_protection_kind>NONE<"), std::string::npos);
  EXPECT_NE(governance_xml(RtpsProtection::kSign).find("<rtps_protection_kind>SIGN<"), std::string::npos);
  const std::string encrypted = governance_xml(parse_rtps_protection("encrypt"));
  EXPECT_NE(encrypted.find("<rtps_protection_kind>ENCRYPT<"), std::string::npos);
  EXPECT_NE(encrypted.find("<data_protection_kind>ENCRYPT<"), std::string::npos) << "the topics stay encrypted";
  EXPECT_THROW(parse_rtps_protection("ENCRYPT"), std::invalid_argument);
}

TEST(LocctlSecurity, EveryIdentitysConfigIsTheShippedTemplateWithItsFolder) {
  std::ifstream in(std::string(LOCD_SOURCE_DIR) + "/config/dds/secure.xml");
  std::stringstream text;
  text << in.rdbuf();
  const std::string shipped = text.str();
  const size_t body = shipped.find("<CycloneDDS");
  ASSERT_NE(body, std::string::npos);
  EXPECT_EQ(shipped.substr(body), cyclone_security_xml("${LOCD_IDENTITY}"));
  EXPECT_NE(cyclone_security_xml("/fleet/robot/r1").find("<Permissions>file:///fleet/robot/r1/permissions.p7s<"),
            std::string::npos);
}

TEST(LocctlSecurity, NamesRolesTimesAndTheCommandLineAreChecked) {
  EXPECT_EQ(parse_role("monitor"), Role::kMonitor);
  EXPECT_THROW(parse_role("admin"), std::invalid_argument);
  EXPECT_EQ(parse_utc("1970-01-02T00:00:00Z"), 86400);
  EXPECT_THROW(parse_utc("2026-01-01 00:00"), std::invalid_argument);
  EXPECT_EQ(subject_openssl(Role::kServer, "srv"), "/O=locd/OU=server/CN=srv");
  const auto run = [](const std::vector<std::string>&, const std::string&, std::string&) { return 0; };
  try {
    make_identity("/nonexistent", Role::kRobot, "bad id", kValidity, run);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("robot name 'bad id' is not allowed; allowed: 1-64 characters of "
                                         "[A-Za-z0-9_.-]"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(make_identity("/nonexistent", Role::kRobot, "r1", kValidity, run), std::runtime_error);

  const CommandLine cl = parse_command_line({"security", "robot", "fleet", "r1", "--days", "7", "--start",
                                             "2026-01-01T00:00:00Z"}, nullptr);
  EXPECT_EQ(cl.command, "security");
  EXPECT_EQ(cl.arguments, (std::vector<std::string>{"robot", "fleet", "r1"}));
  EXPECT_EQ(cl.days, 7);
  EXPECT_EQ(cl.start, "2026-01-01T00:00:00Z");
  EXPECT_THROW(parse_command_line({"security", "wizard", "fleet"}, nullptr), UsageError);
  EXPECT_THROW(parse_command_line({"security", "robot", "fleet"}, nullptr), UsageError);
  EXPECT_THROW(parse_command_line({"status", "--days", "3"}, nullptr), UsageError);
  EXPECT_EQ(parse_command_line({"security", "init", "fleet", "--rtps-protection", "encrypt"}, nullptr).rtps_protection,
            "encrypt");
  const auto usage_error = [](std::vector<std::string> args) {
    try {
      parse_command_line(args, nullptr);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(usage_error({"security", "init", "fleet", "--rtps-protection", "strong"}),
            "--rtps-protection = 'strong'; allowed: none, sign, encrypt");
  EXPECT_EQ(usage_error({"security", "robot", "fleet", "r1", "--rtps-protection", "sign"}),
            "--rtps-protection applies to 'security init' only");
  EXPECT_EQ(usage_error({"status", "--rtps-protection", "sign"}), "--rtps-protection applies to 'security init' only");
}

}  // namespace
