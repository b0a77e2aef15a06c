// Per-robot rate limits on what a robot asks of the server: session requests, initial poses and
// map saves (config key request_limits). Each robot has a token bucket per kind: `burst` requests
// at once, then `per_s` a second. A request over its robot's limit is dropped before it is parsed
// or acted on, and counted. With DDS Security a robot's identity may write only in its own
// partition, so the limit per robot is the limit per identity. The server keeps a second limiter
// keyed by the writer's participant, for the session requests of a writer naming many robots.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>

namespace locd::server {

enum class RequestKind : size_t { kSessionRequest, kInitialPose, kMapSave };
constexpr size_t kRequestKinds = 3;
// The config key of each kind under request_limits, for messages.
const char* request_limit_key(RequestKind kind);

struct RequestRate {
  double per_s = 1.0;
  double burst = 1.0;
};

struct RequestLimits {
  std::array<RequestRate, kRequestKinds> rates{{{1.0, 10.0}, {5.0, 10.0}, {1.0, 5.0}}};
  // Session requests of one writer's participant across every robot it names (an operator, a
  // fleet generator, or in plain mode anyone naming many robots): the burst lets a fleet start.
  RequestRate session_requests_per_participant{20.0, 2000.0};
  const RequestRate& of(RequestKind kind) const { return rates[static_cast<size_t>(kind)]; }
};

class RequestLimiter {
 public:
  using Clock = std::chrono::steady_clock;
  // At most `max_robots` robots are followed. Beyond, robots whose buckets have refilled are
  // forgotten (they hold nothing); if that frees less than a quarter, all are, and each starts
  // again from a full burst.
  explicit RequestLimiter(RequestLimits limits, size_t max_robots = 16384);
  // The same rate for every kind (the kind then only keeps a key's buckets apart).
  explicit RequestLimiter(RequestRate rate, size_t max_robots = 16384);

  // True when the robot may make this request now (a token is taken); false when it is over its
  // limit.
  bool admit(const std::string& robot_id, RequestKind kind, Clock::time_point now = Clock::now());
  size_t robots_followed() const;

 private:
  struct Bucket {
    double tokens = 0.0;
    Clock::time_point refilled{};
  };
  using Buckets = std::array<Bucket, kRequestKinds>;
  Buckets full_buckets(Clock::time_point now) const;
  bool is_full(Buckets& buckets, Clock::time_point now) const;
  void refill(Bucket& bucket, RequestKind kind, Clock::time_point now) const;

  RequestLimits limits_;
  size_t max_robots_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Buckets> robots_;
};

}  // namespace locd::server
