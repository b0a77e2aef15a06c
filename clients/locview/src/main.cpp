// locview: a Foxglove live view of a locd fleet. Open Foxglove, connect to ws://HOST:8765.
// A separate program on DDS (not inside locd): a viewer's crash or a client's garbage never
// costs localization. See `locview --help` and README "Live view".
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "fleet_view.hpp"
#include "locd/dds/dds.hpp"
#include "ws_server.hpp"

namespace {

std::atomic<bool> stop_requested{false};
void on_stop(int) { stop_requested = true; }

}  // namespace

int main(int argc, char** argv) {
  using namespace locd::view;
  ServerLimits limits;
  ViewOptions view;
  std::string address = "127.0.0.1";
  unsigned port = 8765;
  std::string tokens_file;
  std::vector<std::string> origins;
  bool no_token = false;
  CLI::App app{"locview: serves every locd robot's pose, particles, scan, maps, grids, goals, status and transforms\n"
               "to Foxglove over the Foxglove WebSocket protocol (foxglove.websocket.v1). DDS settings come from\n"
               "CYCLONEDDS_URI, as for locd and locctl.",
               "locview"};
  app.add_option("--port", port, "TCP port (default 8765; 0 = any free port, printed at start)")->check(CLI::Range(0, 65535));
  app.add_option("--address", address,
                 "address to listen on (default 127.0.0.1, this machine only; any other address needs --tokens or\n"
                 "LOCVIEW_TOKEN, or --no-token)");
  app.add_option("--tokens", tokens_file,
                 "file of bearer tokens, one per line: TOKEN ROBOT[,ROBOT...] or TOKEN * (mode 0600); a client\n"
                 "sends 'Authorization: Bearer TOKEN' or connects to ws://HOST:PORT/?token=TOKEN and sees only\n"
                 "its token's robots. LOCVIEW_TOKEN=TOKEN (environment) adds a token for every robot");
  app.add_option("--allow-origin", origins,
                 "web origins a browser page may connect from (repeatable; default https://app.foxglove.dev;\n"
                 "'*' any). Clients that send no Origin (Foxglove desktop, scripts) are not asked");
  app.add_flag("--no-token", no_token, "serve an address other than 127.0.0.1 without tokens (every pose to anyone who reaches it)");
  app.add_option("--domain", view.domain_id, "DDS domain id (default 0)")->check(CLI::Range(0, 232));
  app.add_option("--robot", view.robots, "only these robots (repeatable; default every robot)");
  app.add_option("--max-clients", limits.max_clients, "WebSocket clients served at once (default 32)")->check(CLI::Range(1, 4096));
  app.add_option("--max-subscriptions", limits.max_subscriptions_per_client, "subscriptions per client (default 4096)")
      ->check(CLI::Range(1, 1'000'000));
  app.add_option("--max-robots", view.max_robots, "robots given channels (default 1000)")->check(CLI::Range(1, 100'000));
  app.add_option("--max-queued-mb", limits.max_queued_bytes_per_client, "MiB queued to a slow client before its messages are dropped (default 64)")
      ->check(CLI::Range(1, 4096))->transform([](std::string s) { return std::to_string(std::stoull(s) << 20); });
  CLI11_PARSE(app, argc, argv);
  try {
    AccessPolicy access;
    if (!origins.empty()) access.allowed_origins = origins;
    if (!tokens_file.empty()) access.grants = read_tokens_file(tokens_file);
    if (const char* token = std::getenv("LOCVIEW_TOKEN"); token && *token) {
      if (const std::string e = token_error(token); !e.empty()) throw std::runtime_error("LOCVIEW_TOKEN: " + e);
      Grant grant;
      grant.token = token;
      grant.all_robots = true;
      access.grants.push_back(std::move(grant));
    }
    if (access.grants.empty() && address != "127.0.0.1" && address != "::1" && address != "localhost" && !no_token) {
      throw std::runtime_error("--address " + address +
                               " serves other hosts, and no token was given: give --tokens FILE or LOCVIEW_TOKEN, "
                               "or --no-token to serve every pose to anyone who reaches it");
    }
    FoxgloveServer server("locview (locd fleet)", address, static_cast<uint16_t>(port), limits, access);
    FleetView fleet(server, view);
    std::signal(SIGINT, on_stop);
    std::signal(SIGTERM, on_stop);
    std::cout << "locview: serving the fleet of DDS domain " << view.domain_id << " on ws://" << address << ":"
              << server.port() << " (foxglove.websocket.v1); CYCLONEDDS_URI="
              << (locd::dds::config_uri().empty() ? "unset" : locd::dds::config_uri()) << "; "
              << (access.grants.empty() ? std::string("no token asked")
                                        : std::to_string(access.grants.size()) + " tokens")
              << std::endl;
    while (!stop_requested) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const ServerCounters c = server.counters();
    std::cout << "locview: stopped; " << fleet.robots() << " robots, " << c.messages_sent << " messages sent, "
              << c.messages_dropped << " dropped, " << c.refused_clients << " clients refused, " << c.client_errors
              << " client errors" << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "locview: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
