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
//           was cut off and came back): the older claim stops, so a server that returns after a
//           network cut hands its robots to the one that took them over (ties: the lower rank
//           stops).
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
  // A live server serves the robot since `since_ns` (wall clock), or stopped (or died: all its
  // claims go with it).
  void claim(const std::string& robot_id, const std::string& server_id, bool serving, int64_t since_ns = 0);

  enum class Decision {
    kServe,   // start (or keep) serving the robot here
    kYield,   // another live server serves it with a newer claim: stop here
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
  std::map<std::string, std::map<std::string, int64_t>> claims_;  // robot -> claiming server -> since
};

}  // namespace locd::server
