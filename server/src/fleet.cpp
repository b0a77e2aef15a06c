#include "locd/server/fleet.hpp"

#include <algorithm>
#include <cmath>

namespace locd::server {
namespace {

// 64-bit FNV-1a over the robot id, a separator and the server id, then a finaliser (SplitMix64)
// so that nearby strings give unrelated numbers. The same on every server and every run.
uint64_t pair_hash(const std::string& robot_id, const std::string& server_id) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](unsigned char c) {
    h ^= c;
    h *= 1099511628211ull;
  };
  for (const char c : robot_id) mix(static_cast<unsigned char>(c));
  mix(0);
  for (const char c : server_id) mix(static_cast<unsigned char>(c));
  h += 0x9e3779b97f4a7c15ull;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

// Weighted rendezvous score: -w / ln(u) with u uniform in (0, 1); the highest wins. A server of
// weight w then wins a share of robots proportional to w.
double score(const std::string& robot_id, const ServerMember& server) {
  const double u = (static_cast<double>(pair_hash(robot_id, server.id) >> 11) + 0.5) / 9007199254740992.0;
  return -server.weight / std::log(u);
}

// 2025-01-01T00:00:00Z, and the largest term a strength holds.
constexpr int64_t kStrengthEpochS = 1735689600;
constexpr int64_t kMaxTerm = (int64_t{1} << 23) - 1;

}  // namespace

int32_t claim_strength(const std::string& server_id, int32_t strongest_known, int64_t wall_ns) {
  const int64_t minutes = (wall_ns / 1'000'000'000 - kStrengthEpochS) / 60;
  const int64_t term = std::clamp<int64_t>(std::max<int64_t>(minutes, (strongest_known >> 8) + 1), 1, kMaxTerm);
  const int64_t slot = static_cast<int64_t>(pair_hash("", server_id) & 0xff);
  return static_cast<int32_t>((term << 8) | slot);
}

std::vector<std::string> rendezvous_order(const std::string& robot_id, const std::string& group,
                                          const std::vector<ServerMember>& servers) {
  std::vector<std::pair<double, std::string>> scored;
  for (const auto& s : servers) {
    if (!group.empty() && s.group != group) continue;
    if (!(s.weight > 0.0)) continue;
    scored.emplace_back(score(robot_id, s), s.id);
  }
  std::sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  std::vector<std::string> order;
  for (auto& [_, id] : scored) order.push_back(std::move(id));
  return order;
}

FleetView::FleetView(ServerMember self) : self_(std::move(self)) { alive_[self_.id] = self_; }

void FleetView::server_alive(const ServerMember& member) { alive_[member.id] = member; }

void FleetView::server_gone(const std::string& server_id) {
  if (server_id == self_.id) return;
  alive_.erase(server_id);
  for (auto it = claims_.begin(); it != claims_.end();) {
    it->second.erase(server_id);
    it = it->second.empty() ? claims_.erase(it) : std::next(it);
  }
}

void FleetView::claim(const std::string& robot_id, const std::string& server_id, bool serving, int64_t since_ns,
                      int32_t strength) {
  if (serving) {
    claims_[robot_id][server_id] = {since_ns, strength};
    return;
  }
  auto it = claims_.find(robot_id);
  if (it == claims_.end()) return;
  it->second.erase(server_id);
  if (it->second.empty()) claims_.erase(it);
}

std::vector<ServerMember> FleetView::alive() const {
  std::vector<ServerMember> out;
  for (const auto& [_, m] : alive_) out.push_back(m);
  return out;
}

std::vector<std::string> FleetView::claimants(const std::string& robot_id) const {
  std::vector<std::string> out;
  auto it = claims_.find(robot_id);
  if (it == claims_.end()) return out;
  for (const auto& [id, _] : it->second) {
    if (alive_.count(id)) out.push_back(id);
  }
  return out;
}

FleetView::Decision FleetView::decide(const std::string& robot_id, const std::string& group, bool serving) const {
  std::vector<std::string> others;
  for (const auto& id : claimants(robot_id)) {
    if (id != self_.id) others.push_back(id);
  }
  const std::vector<std::string> order = rendezvous_order(robot_id, group, alive());
  auto rank = [&](const std::string& id) {
    const auto it = std::find(order.begin(), order.end(), id);
    return it == order.end() ? order.size() : static_cast<size_t>(it - order.begin());
  };
  if (serving) {
    // Settle a double claim: the weaker claim stops (equal strengths: the older, then the lower
    // rank), as DDS gives the robot the stronger claim's outputs.
    const auto& claims = claims_.count(robot_id) ? claims_.at(robot_id) : std::map<std::string, Claim>{};
    const auto found = claims.find(self_.id);
    const Claim mine = found == claims.end() ? Claim{} : found->second;
    for (const auto& other : others) {
      const Claim& theirs = claims.at(other);
      if (theirs.strength != mine.strength) {
        if (theirs.strength > mine.strength) return Decision::kYield;
        continue;
      }
      if (theirs.since_ns > mine.since_ns || (theirs.since_ns == mine.since_ns && rank(other) < rank(self_.id))) {
        return Decision::kYield;
      }
    }
    return Decision::kServe;
  }
  if (!others.empty()) return Decision::kLeave;  // served elsewhere: stick with it
  return !order.empty() && order.front() == self_.id ? Decision::kServe : Decision::kLeave;
}

bool FleetView::answers_for(const std::string& robot_id, const std::string& group) const {
  if (!claimants(robot_id).empty()) return false;
  const std::vector<std::string> order = rendezvous_order(robot_id, group, alive());
  // A robot whose group has no live server is answered by every server: it must hear why.
  return order.empty() || order.front() == self_.id;
}

}  // namespace locd::server
