// Per-robot rate limits (request_limiter.hpp): the token bucket against the count it must give,
// robots apart, kinds apart, and the bound on the robots it follows.
#include <gtest/gtest.h>

#include "locd/server/request_limiter.hpp"

namespace {

using locd::server::RequestKind;
using locd::server::RequestLimiter;
using locd::server::RequestLimits;
using Clock = RequestLimiter::Clock;
using namespace std::chrono_literals;

RequestLimits limits(double per_s, double burst) {
  RequestLimits l;
  for (auto& r : l.rates) r = {per_s, burst};
  return l;
}

// Requests every `period` for `duration`, from one robot: how many were admitted.
int admitted(RequestLimiter& limiter, const std::string& robot, RequestKind kind, Clock::time_point start,
             Clock::duration period, Clock::duration duration) {
  int n = 0;
  for (auto t = start; t < start + duration; t += period) n += limiter.admit(robot, kind, t);
  return n;
}

TEST(RequestLimiter, AdmitsTheBurstThenTheRateAndNoMore) {
  // Asked 100 times a second for 10 s at 2 a second with a burst of 5: the burst, then one every
  // 0.5 s: 5 + floor(2 * 9.99) = 24 (the last refill lands at 9.5 s; at 10.0 s the run has ended).
  RequestLimiter limiter(limits(2.0, 5.0));
  const auto t0 = Clock::time_point{} + 1000s;
  EXPECT_EQ(admitted(limiter, "a", RequestKind::kSessionRequest, t0, 10ms, 10s), 5 + 19);
  // Asked no faster than the rate: every one admitted.
  RequestLimiter slow(limits(2.0, 5.0));
  EXPECT_EQ(admitted(slow, "a", RequestKind::kSessionRequest, t0, 500ms, 60s), 120);
}

TEST(RequestLimiter, OneRateForEveryKindCountsTheSame) {
  RequestLimiter limiter(locd::server::RequestRate{2.0, 5.0});
  const auto t0 = Clock::time_point{} + 1000s;
  EXPECT_EQ(admitted(limiter, "a", RequestKind::kMapSave, t0, 10ms, 10s), 5 + 19);
  EXPECT_EQ(admitted(limiter, "a", RequestKind::kInitialPose, t0, 10ms, 10s), 5 + 19);
}

TEST(RequestLimiter, RefillsToTheBurstAndNotBeyond) {
  RequestLimiter limiter(limits(1.0, 3.0));
  const auto t0 = Clock::time_point{} + 1000s;
  EXPECT_EQ(admitted(limiter, "a", RequestKind::kInitialPose, t0, 1ms, 10ms), 3);
  // An hour idle gives back the burst, not 3600.
  EXPECT_EQ(admitted(limiter, "a", RequestKind::kInitialPose, t0 + 3600s, 1ms, 10ms), 3);
  // Fractions add up: 0.4 s + 0.4 s + 0.4 s is one token.
  EXPECT_FALSE(limiter.admit("a", RequestKind::kInitialPose, t0 + 3600s + 400ms));
  EXPECT_FALSE(limiter.admit("a", RequestKind::kInitialPose, t0 + 3600s + 800ms));
  EXPECT_TRUE(limiter.admit("a", RequestKind::kInitialPose, t0 + 3600s + 1200ms));
}

TEST(RequestLimiter, RobotsAndKindsHaveBucketsOfTheirOwn) {
  RequestLimits l = limits(1.0, 2.0);
  l.rates[static_cast<size_t>(RequestKind::kMapSave)] = {1.0, 4.0};
  RequestLimiter limiter(l);
  const auto t = Clock::time_point{} + 1000s;
  EXPECT_EQ(admitted(limiter, "flooder", RequestKind::kSessionRequest, t, 1us, 1ms), 2);
  EXPECT_EQ(admitted(limiter, "quiet", RequestKind::kSessionRequest, t, 1us, 1ms), 2);
  EXPECT_EQ(admitted(limiter, "flooder", RequestKind::kInitialPose, t, 1us, 1ms), 2);
  EXPECT_EQ(admitted(limiter, "flooder", RequestKind::kMapSave, t, 1us, 1ms), 4);
}

TEST(RequestLimiter, FollowsAtMostMaxRobotsAndForgetsOnlyRefilledOnesWhileItCan) {
  RequestLimiter limiter(limits(1.0, 2.0), 8);
  const auto t = Clock::time_point{} + 1000s;
  // Every second a new robot asks once (refilled a second later), and a flooder asks three times:
  // followed all along, it gets the one token a second; forgotten, it would get a new burst.
  for (int i = 0; i < 100; ++i) {
    const auto now = t + i * 1s;
    EXPECT_TRUE(limiter.admit("robot_" + std::to_string(i), RequestKind::kSessionRequest, now));
    int flooder = 0;
    for (int k = 0; k < 3; ++k) flooder += limiter.admit("flooder", RequestKind::kSessionRequest, now);
    EXPECT_EQ(flooder, i == 0 ? 2 : 1) << "second " << i;
    EXPECT_LE(limiter.robots_followed(), 8u);
  }
  // Robots that all stay busy: the bound holds by starting again.
  RequestLimiter busy(limits(1.0, 2.0), 8);
  for (int i = 0; i < 100; ++i) {
    const std::string id = "busy_" + std::to_string(i);
    EXPECT_TRUE(busy.admit(id, RequestKind::kSessionRequest, t));
    EXPECT_LE(busy.robots_followed(), 8u);
  }
}

}  // namespace
