// Who may use locview: bearer tokens, each bound to the robots its holder may see, and the web
// origins a browser page may connect from. No I/O here but reading the tokens file; the WebSocket
// server asks `admit` for each connection before it opens.
#pragma once

#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace locd::view {

struct Grant {
  std::string token;
  bool all_robots = false;
  std::set<std::string> robots;  // when not all_robots
  bool sees(const std::string& robot) const { return all_robots || robots.count(robot) > 0; }
};

struct AccessPolicy {
  // Empty: no token is asked for (locview on 127.0.0.1 for this machine's user).
  std::vector<Grant> grants;
  // A request that carries an Origin header (a browser page) must name one of these; "*" allows
  // any. Requests without an Origin (Foxglove desktop, scripts) are not asked.
  std::vector<std::string> allowed_origins = {"https://app.foxglove.dev"};
};

// Tokens: 16 to 256 characters of A-Z a-z 0-9 - . _ ~ (they travel in a URL's query).
inline constexpr size_t kMinTokenLength = 16;
inline constexpr size_t kMaxTokenLength = 256;
// Empty when `token` may be a token, else what is wrong with it (never the token itself).
std::string token_error(const std::string& token);

// Reads a tokens file: one grant per line, `TOKEN ROBOT[,ROBOT...]` or `TOKEN *`; blank lines and
// lines starting with '#' are skipped. The file must be readable by its owner only (mode 0600 or
// 0400). Throws std::runtime_error naming the file, the line and what is allowed.
std::vector<Grant> read_tokens_file(const std::filesystem::path& file);

// The connection's verdict: the grant it was admitted with (nullptr when no token is asked for),
// or the HTTP status and the reason it was refused.
struct Admission {
  bool admitted = false;
  const Grant* grant = nullptr;
  int http_status = 0;
  std::string reason;
};
// authorization: the request's Authorization header; resource: its request target ("/?token=...");
// origin: its Origin header (empty when absent). Every grant's token is compared in constant time.
Admission admit(const AccessPolicy& policy, const std::string& authorization, const std::string& resource,
                const std::string& origin);

}  // namespace locd::view
