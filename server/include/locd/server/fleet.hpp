// Many servers, one fleet: which server serves which robot. No broker and no consensus protocol:
// every server sees the same facts through DDS and applies the same rules.
//
//   facts   the live servers (ServerInfo: id, weight, group; liveliness says who is alive), and
//           which live server claims which robot (ServingClaim, written while a server serves).
//   choose  a robot that no live server serves goes to the first of its eligible servers (those
//           of the robot's server group, or all) in weighted rendezvous order: each server scores
//           -weight / ln(h) with h = hash(robot, server) in (0, 1), highest first. Robots spread
//           over the servers in proportion to their weights, and a server's death moves only
//           its own robots.
//   stick   a robot stays with the live server that serves it: a server that comes back, or a
//           new one, takes no robot away (no flapping).
//   settle  two servers that both serve a robot (they started it before they saw each other, or one
//           was stalled or cut off and came back): the weaker claim stops (claim_strength below:
//           a takeover is always stronger than the claim it took over), so a server that returns
//           after a stall or a network cut hands its robots to the one that took them over
//           (equal strengths: the older claim stops, then the lower rank).
//   own     the serving server writes the robot's outputs with its claim's strength as their
//           DDS ownership strength (exclusive ownership, dds.hpp): a robot's reader takes them
//           from the strongest live writer only, so while two servers overlap (a stalled server
//           resuming, a cut that heals) the robot never gets one stamp's pose from both.
// A lone server is first for every robot and serves every request at once, as before.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace locd::server {

struct ServerMember {
  std::string id;
  double weight = 1.0;
  std::string group;  // empty: no group
};

// The strength of a new claim on a robot: term << 8 | slot, with
//   term  the minutes since 2025-01-01 (wall clock), or more: above the term of the strongest
//         claim on the robot this server knows of (`strongest_known`: others' claims, its own,
//         the state file's). A new claim then outranks every earlier one, also that of a killed
//         server whose writers DDS counts alive until their lease ends, and, by the wall clock,
//         those of a server that restarted without a state file;
//   slot  8 bits of a hash of the server id: two servers that claim a robot in the same minute
//         without knowing of each other still differ (unless their hashes collide, 1 in 256).
// The term is bounded at 2^23 - 1 (the year 2040 by the clock).
int32_t claim_strength(const std::string& server_id, int32_t strongest_known, int64_t wall_ns);

// Eligible servers of a robot, best first (weighted rendezvous hashing). `group` empty: all.
std::vector<std::string> rendezvous_order(const std::string& robot_id, const std::string& group,
                                          const std::vector<ServerMember>& servers);

class FleetView {
 public:
  explicit FleetView(ServerMember self);

  const ServerMember& self() const { return self_; }
  // What discovery says: a server is alive (its ServerInfo, again at any change) or gone.
  void server_alive(const ServerMember& member);
  void server_gone(const std::string& server_id);
  // A live server serves the robot since `since_ns` (wall clock) with a claim of `strength`
  // (claim_strength), or stopped (or died: all its claims go with it).
  void claim(const std::string& robot_id, const std::string& server_id, bool serving, int64_t since_ns = 0,
             int32_t strength = 0);

  enum class Decision {
    kServe,   // start (or keep) serving the robot here
    kYield,   // another live server serves it with a stronger claim: stop here
    kLeave,   // another live server serves it (or ranks first): nothing to do here
  };
  // For a robot whose latest request asks for a session, in server group `group`, when this
  // server does (`serving`) or does not serve it.
  Decision decide(const std::string& robot_id, const std::string& group, bool serving) const;
  // The live servers that claim the robot (this one included if it does).
  std::vector<std::string> claimants(const std::string& robot_id) const;
  // True when this server would answer for a robot nobody serves ("no session" statuses).
  bool answers_for(const std::string& robot_id, const std::string& group) const;
  std::vector<ServerMember> alive() const;

 private:
  ServerMember self_;
  std::map<std::string, ServerMember> alive_;                  // by id, self included
  struct Claim {
    int64_t since_ns = 0;
    int32_t strength = 0;
  };
  std::map<std::string, std::map<std::string, Claim>> claims_;  // robot -> claiming server -> claim
};

}  // namespace locd::server
