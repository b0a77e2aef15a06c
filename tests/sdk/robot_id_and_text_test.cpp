// Robot ids (what may name a partition and a log subject) and the escaping of network text.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"

namespace locd {
namespace {

TEST(RobotId, PlainIdsOfOneTo64AllowedCharactersPass) {
  EXPECT_EQ(robot_id_error("r"), "");
  EXPECT_EQ(robot_id_error("corridor_bot-2.fleet_A"), "");
  EXPECT_EQ(robot_id_error(std::string(64, 'x')), "");
}

TEST(RobotId, EverythingElseIsRefusedNamingWhatIsAllowed) {
  const std::string allowed = "allowed: 1-64 characters of [A-Za-z0-9_.-]";
  EXPECT_NE(robot_id_error("").find("robot_id is empty; " + allowed), std::string::npos);
  EXPECT_NE(robot_id_error(std::string(65, 'x')).find("is 65 characters; " + allowed), std::string::npos);
  // A wildcard would widen a partition; a space, a slash or a newline has no business in a name.
  for (const std::string bad : {"robot*", "robot?", "a b", "a/b", "tab\there"}) {
    EXPECT_NE(robot_id_error(bad).find(allowed), std::string::npos) << bad;
  }
  const std::string forged = robot_id_error("x\n2026-01-01 info [server] forged");
  EXPECT_EQ(forged.find('\n'), std::string::npos) << forged;
  EXPECT_NE(forged.find("contains '\\n'"), std::string::npos) << forged;
  EXPECT_THROW(check_robot_id("no spaces"), std::invalid_argument);
  EXPECT_NO_THROW(check_robot_id("ok"));
}

TEST(Escaped, ControlAndNonAsciiBytesBecomeVisibleAndLongTextIsCut) {
  EXPECT_EQ(escaped("plain text: [ok] 1.5"), "plain text: [ok] 1.5");
  EXPECT_EQ(escaped("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(escaped(std::string("nul\0x", 5)), "nul\\x00x");
  EXPECT_EQ(escaped("\xc3\xa9"), "\\xc3\\xa9");
  // Escaping twice changes nothing more: a backslash stays as it is.
  EXPECT_EQ(escaped(escaped("a\nb")), "a\\nb");
  EXPECT_EQ(escaped(std::string(10, 'y'), 4), "yyyy...(10 bytes)");
}

}  // namespace
}  // namespace locd
