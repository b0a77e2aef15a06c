#include "access.hpp"

#include <sys/stat.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/text.hpp"

namespace locd::view {
namespace {

bool token_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '.' ||
         c == '_' || c == '~';
}

// Equal or not, in time that depends on the lengths only (never on where they differ).
bool constant_time_equal(const std::string& a, const std::string& b) {
  const size_t n = std::max(a.size(), b.size());
  unsigned char diff = a.size() != b.size() ? 1 : 0;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

// The value of `token=` in the request target's query, or empty.
std::string query_token(const std::string& resource) {
  const size_t q = resource.find('?');
  if (q == std::string::npos) return {};
  std::string query = resource.substr(q + 1);
  size_t start = 0;
  while (start <= query.size()) {
    const size_t end = std::min(query.find('&', start), query.size());
    const std::string pair = query.substr(start, end - start);
    if (pair.rfind("token=", 0) == 0) return pair.substr(6);
    start = end + 1;
  }
  return {};
}

}  // namespace

std::string token_error(const std::string& token) {
  if (token.size() < kMinTokenLength || token.size() > kMaxTokenLength) {
    return "a token has " + std::to_string(kMinTokenLength) + " to " + std::to_string(kMaxTokenLength) +
           " characters, this one " + std::to_string(token.size());
  }
  for (char c : token) {
    if (!token_char(c)) return "a token holds only A-Z a-z 0-9 - . _ ~";
  }
  return {};
}

std::vector<Grant> read_tokens_file(const std::filesystem::path& file) {
  const std::string name = "tokens file '" + escaped(file.string()) + "'";
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) throw std::runtime_error(name + " cannot be read");
  if (!S_ISREG(st.st_mode)) throw std::runtime_error(name + " is not a regular file");
  if ((st.st_mode & 077) != 0) {
    std::ostringstream mode;
    mode << std::oct << (st.st_mode & 0777);
    throw std::runtime_error(name + " has mode 0" + mode.str() +
                             ": others could read the tokens; allowed: readable by its owner only (chmod 600)");
  }
  if (st.st_size > (1 << 20)) throw std::runtime_error(name + " is larger than 1 MiB");
  std::ifstream in(file);
  if (!in) throw std::runtime_error(name + " cannot be read");
  std::vector<Grant> grants;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = name + " line " + std::to_string(number) + ": ";
    std::istringstream words(line);
    std::string token, robots, extra;
    if (!(words >> token) || token[0] == '#') continue;
    if (!(words >> robots)) throw std::runtime_error(where + "a token without robots; allowed: TOKEN ROBOT[,ROBOT...] or TOKEN *");
    if (words >> extra) throw std::runtime_error(where + "'" + escaped(extra) + "' after the robots; robots are separated by ',' without spaces");
    if (const std::string e = token_error(token); !e.empty()) throw std::runtime_error(where + e);
    for (const Grant& g : grants) {
      if (g.token == token) throw std::runtime_error(where + "the token of an earlier line again");
    }
    Grant grant;
    grant.token = token;
    if (robots == "*") {
      grant.all_robots = true;
    } else {
      std::istringstream list(robots);
      std::string robot;
      while (std::getline(list, robot, ',')) {
        if (const std::string e = robot_id_error(robot); !e.empty()) throw std::runtime_error(where + e);
        grant.robots.insert(robot);
      }
      if (grant.robots.empty()) throw std::runtime_error(where + "no robot; allowed: TOKEN ROBOT[,ROBOT...] or TOKEN *");
    }
    grants.push_back(std::move(grant));
  }
  if (grants.empty()) throw std::runtime_error(name + " holds no token");
  return grants;
}

Admission admit(const AccessPolicy& policy, const std::string& authorization, const std::string& resource,
                const std::string& origin) {
  Admission a;
  if (!origin.empty()) {
    bool allowed = false;
    for (const auto& o : policy.allowed_origins) allowed = allowed || o == "*" || o == origin;
    if (!allowed) {
      a.http_status = 403;
      a.reason = "origin '" + escaped(origin.substr(0, 128)) + "' is not allowed (locview --allow-origin)";
      return a;
    }
  }
  if (policy.grants.empty()) {
    a.admitted = true;
    return a;
  }
  std::string presented;
  if (authorization.rfind("Bearer ", 0) == 0) {
    presented = authorization.substr(7);
  } else {
    presented = query_token(resource);
  }
  if (presented.empty()) {
    a.http_status = 401;
    a.reason = "no token (send 'Authorization: Bearer TOKEN' or connect to ws://HOST:PORT/?token=TOKEN)";
    return a;
  }
  const Grant* match = nullptr;
  if (presented.size() <= kMaxTokenLength) {
    for (const Grant& g : policy.grants) {
      if (constant_time_equal(g.token, presented) && !match) match = &g;  // every grant compared
    }
  }
  if (!match) {
    a.http_status = 401;
    a.reason = "the token is not valid";
    return a;
  }
  a.admitted = true;
  a.grant = match;
  return a;
}

}  // namespace locd::view
