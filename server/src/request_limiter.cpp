#include "locd/server/request_limiter.hpp"

#include <algorithm>

namespace locd::server {

const char* request_limit_key(RequestKind kind) {
  switch (kind) {
    case RequestKind::kSessionRequest: return "request_limits.session_requests";
    case RequestKind::kInitialPose: return "request_limits.initial_poses";
    case RequestKind::kMapSave: return "request_limits.map_saves";
  }
  return "request_limits";
}

RequestLimiter::RequestLimiter(RequestLimits limits, size_t max_robots)
    : limits_(limits), max_robots_(std::max<size_t>(max_robots, 1)) {}

RequestLimiter::RequestLimiter(RequestRate rate, size_t max_robots) : RequestLimiter(RequestLimits{}, max_robots) {
  limits_.rates.fill(rate);
}

void RequestLimiter::refill(Bucket& bucket, RequestKind kind, Clock::time_point now) const {
  const RequestRate& rate = limits_.of(kind);
  const double elapsed_s = std::chrono::duration<double>(now - bucket.refilled).count();
  if (elapsed_s > 0.0) {
    bucket.tokens = std::min(rate.burst, bucket.tokens + elapsed_s * rate.per_s);
    bucket.refilled = now;
  }
}

RequestLimiter::Buckets RequestLimiter::full_buckets(Clock::time_point now) const {
  Buckets buckets;
  for (size_t k = 0; k < kRequestKinds; ++k) buckets[k] = {limits_.rates[k].burst, now};
  return buckets;
}

bool RequestLimiter::is_full(Buckets& buckets, Clock::time_point now) const {
  for (size_t k = 0; k < kRequestKinds; ++k) {
    refill(buckets[k], static_cast<RequestKind>(k), now);
    if (buckets[k].tokens < limits_.rates[k].burst) return false;
  }
  return true;
}

bool RequestLimiter::admit(const std::string& robot_id, RequestKind kind, Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = robots_.find(robot_id);
  if (it == robots_.end()) {
    if (robots_.size() >= max_robots_) {
      for (auto r = robots_.begin(); r != robots_.end();) {
        r = is_full(r->second, now) ? robots_.erase(r) : std::next(r);
      }
      // Too few freed to pay for the next sweep: start again (each robot from a full burst).
      if (robots_.size() > max_robots_ * 3 / 4) robots_.clear();
    }
    it = robots_.emplace(robot_id, full_buckets(now)).first;
  }
  Bucket& bucket = it->second[static_cast<size_t>(kind)];
  refill(bucket, kind, now);
  if (bucket.tokens < 1.0) return false;
  bucket.tokens -= 1.0;
  return true;
}

size_t RequestLimiter::robots_followed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robots_.size();
}

}  // namespace locd::server
