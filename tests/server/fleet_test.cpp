// Which server serves which robot (fleet.hpp): weighted rendezvous order against its definition,
// the spread over servers in proportion to their weights, groups, a dead server's robots moving
// and only those, no robot moving to a server that comes back, a double claim settled for the
// stronger claim (then by rank), and claim strengths that outrank what came before.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "locd/server/fleet.hpp"

namespace {

using locd::server::claim_strength;
using locd::server::FleetView;
using locd::server::rendezvous_order;
using locd::server::ServerMember;
using Decision = FleetView::Decision;

std::string robot(int i) { return "robot_" + std::to_string(i); }

TEST(Rendezvous, OrderIsTheSameEverywhereAndCoversEveryEligibleServer) {
  const std::vector<ServerMember> servers = {{"a", 1.0, ""}, {"b", 1.0, ""}, {"c", 1.0, "east"}};
  const auto order = rendezvous_order("r1", "", servers);
  ASSERT_EQ(order.size(), 3u);
  const std::vector<ServerMember> shuffled = {servers[2], servers[0], servers[1]};
  EXPECT_EQ(rendezvous_order("r1", "", shuffled), order);  // independent of discovery order
  EXPECT_EQ(rendezvous_order("r1", "east", servers), std::vector<std::string>{"c"});
  EXPECT_TRUE(rendezvous_order("r1", "west", servers).empty());
}

TEST(Rendezvous, RobotsSpreadInProportionToTheWeights) {
  const std::vector<ServerMember> servers = {{"a", 1.0, ""}, {"b", 1.0, ""}, {"c", 2.0, ""}};
  std::map<std::string, int> count;
  constexpr int kRobots = 20000;
  for (int i = 0; i < kRobots; ++i) ++count[rendezvous_order(robot(i), "", servers).front()];
  // Expected shares 1/4, 1/4, 1/2; binomial standard deviation ~ 61 and 71 robots.
  EXPECT_NEAR(count["a"], kRobots / 4, 300);
  EXPECT_NEAR(count["b"], kRobots / 4, 300);
  EXPECT_NEAR(count["c"], kRobots / 2, 350);
}

TEST(Rendezvous, ADeadServersRobotsAndOnlyThoseMove) {
  const std::vector<ServerMember> three = {{"a", 1.0, ""}, {"b", 1.0, ""}, {"c", 1.0, ""}};
  const std::vector<ServerMember> two = {three[0], three[2]};
  for (int i = 0; i < 3000; ++i) {
    const auto before = rendezvous_order(robot(i), "", three).front();
    const auto after = rendezvous_order(robot(i), "", two).front();
    if (before != "b") EXPECT_EQ(after, before) << robot(i);
  }
}

TEST(FleetView, ALoneServerServesEveryRobot) {
  FleetView view({"a", 1.0, ""});
  EXPECT_EQ(view.decide("r1", "", false), Decision::kServe);
  EXPECT_EQ(view.decide("r1", "", true), Decision::kServe);
  EXPECT_TRUE(view.answers_for("r1", ""));
  EXPECT_EQ(view.decide("r1", "east", false), Decision::kLeave);  // not of that group
}

TEST(FleetView, ServedRobotsStayWhereTheyAreUntilTheirServerDies) {
  FleetView a({"a", 1.0, ""});
  a.server_alive({"b", 1.0, ""});
  // A robot that ranks b first but is served by a (b came back after a took it): it stays.
  std::string r;
  for (int i = 0; r.empty(); ++i) {
    if (rendezvous_order(robot(i), "", a.alive()).front() == "b") r = robot(i);
  }
  EXPECT_EQ(a.decide(r, "", true), Decision::kServe);
  FleetView b({"b", 1.0, ""});
  b.server_alive({"a", 1.0, ""});
  b.claim(r, "a", true);
  EXPECT_EQ(b.decide(r, "", false), Decision::kLeave);  // no flapping
  EXPECT_FALSE(b.answers_for(r, ""));
  // a dies: its claim goes with it, and b, first in the order, takes the robot.
  b.server_gone("a");
  EXPECT_TRUE(b.claimants(r).empty());
  EXPECT_EQ(b.decide(r, "", false), Decision::kServe);
}

TEST(FleetView, ADoubleClaimIsSettledForTheNewestClaim) {
  // b took the robots over while a was cut off (newer claims); a comes back still serving them:
  // a hands them over, b keeps them. No robot moves back.
  FleetView a({"a", 1.0, ""}), b({"b", 1.0, ""});
  a.server_alive({"b", 1.0, ""});
  b.server_alive({"a", 1.0, ""});
  for (int i = 0; i < 50; ++i) {
    const std::string r = robot(i);
    a.claim(r, "a", true, 1000);
    a.claim(r, "b", true, 2000);
    b.claim(r, "b", true, 2000);
    b.claim(r, "a", true, 1000);
    EXPECT_EQ(a.decide(r, "", true), Decision::kYield) << r;
    EXPECT_EQ(b.decide(r, "", true), Decision::kServe) << r;
  }
}

TEST(FleetView, ADoubleClaimAtTheSameInstantIsSettledByRank) {
  FleetView a({"a", 1.0, ""}), b({"b", 1.0, ""});
  a.server_alive({"b", 1.0, ""});
  b.server_alive({"a", 1.0, ""});
  for (int i = 0; i < 50; ++i) {
    const std::string r = robot(i);
    for (FleetView* view : {&a, &b}) {
      view->claim(r, "a", true, 5);
      view->claim(r, "b", true, 5);
    }
    const bool a_first = rendezvous_order(r, "", a.alive()).front() == "a";
    EXPECT_EQ(a.decide(r, "", true), a_first ? Decision::kServe : Decision::kYield) << r;
    EXPECT_EQ(b.decide(r, "", true), a_first ? Decision::kYield : Decision::kServe) << r;
  }
}

TEST(FleetView, TheStrongerClaimWinsWhateverItsTime) {
  // A stronger claim made earlier by the wall clock (another host's clock runs behind) still
  // wins: the robot's readers take the stronger writer's outputs, so the weaker claim stops.
  FleetView a({"a", 1.0, ""}), b({"b", 1.0, ""});
  a.server_alive({"b", 1.0, ""});
  b.server_alive({"a", 1.0, ""});
  for (int i = 0; i < 50; ++i) {
    const std::string r = robot(i);
    for (FleetView* view : {&a, &b}) {
      view->claim(r, "a", true, 9000, 100);
      view->claim(r, "b", true, 1000, 200);
    }
    EXPECT_EQ(a.decide(r, "", true), Decision::kYield) << r;
    EXPECT_EQ(b.decide(r, "", true), Decision::kServe) << r;
  }
}

TEST(ClaimStrength, ANewClaimOutranksEveryKnownOneAndTheClock) {
  const int64_t minute_ns = 60'000'000'000;
  const int64_t now_ns = (int64_t{1735689600} + 400 * 24 * 3600) * 1'000'000'000;  // 400 days after 2025-01-01
  const int32_t first = claim_strength("server1", 0, now_ns);
  EXPECT_EQ(first >> 8, 400 * 24 * 60);  // the term is the minutes since 2025-01-01
  // Above a known claim of any server, also one made in this minute or later by a faster clock.
  EXPECT_GT(claim_strength("server2", first, now_ns), first);
  const int32_t ahead = claim_strength("server3", 0, now_ns + 90 * minute_ns);
  EXPECT_GT(claim_strength("server1", ahead, now_ns), ahead);
  // A later minute outranks without knowing (a server restarted without its state file).
  EXPECT_GT(claim_strength("server1", 0, now_ns + minute_ns), first);
  // Two servers in one minute without knowing of each other: different strengths (their slots).
  std::set<int32_t> slots;
  for (int s = 0; s < 20; ++s) slots.insert(claim_strength("server" + std::to_string(s), 0, now_ns) & 0xff);
  EXPECT_GE(slots.size(), 18u);
  // Bounded: never negative, whatever is known.
  EXPECT_GT(claim_strength("server1", std::numeric_limits<int32_t>::max(), now_ns), 0);
}

TEST(FleetView, AnUnservedRobotIsTakenByTheFirstServerOnly) {
  FleetView a({"a", 1.0, ""}), b({"b", 1.0, ""});
  a.server_alive({"b", 1.0, ""});
  b.server_alive({"a", 1.0, ""});
  for (int i = 0; i < 50; ++i) {
    const std::string r = robot(i);
    const bool take_a = a.decide(r, "", false) == Decision::kServe;
    const bool take_b = b.decide(r, "", false) == Decision::kServe;
    EXPECT_NE(take_a, take_b) << r;
    EXPECT_NE(a.answers_for(r, ""), b.answers_for(r, "")) << r;
  }
}

}  // namespace
