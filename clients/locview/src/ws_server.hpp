// A Foxglove WebSocket server (protocol foxglove.websocket.v1) on websocketpp: channels are
// advertised to every client, clients subscribe and receive each message as a binary Message
// Data frame. Everything a client can make the server hold is bounded (ServerLimits): clients,
// subscriptions per client, the size of a message from a client, the bytes queued to a slow
// client (beyond which its messages are dropped and it is told once). A client's garbage
// (not JSON, unknown op, unknown channel, bad fields, binary frames) gets a status message
// naming what was wrong; the server and every other client carry on.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "access.hpp"

namespace locd::view {

struct ServerLimits {
  size_t max_clients = 32;
  size_t max_subscriptions_per_client = 4096;
  size_t max_client_message_bytes = 64 * 1024;
  size_t max_queued_bytes_per_client = 64u << 20;
  size_t max_channels = 65536;
};

struct ServerCounters {
  uint64_t clients = 0;            // connected now
  uint64_t refused_clients = 0;    // over max_clients, without the subprotocol, token or an allowed origin
  uint64_t client_errors = 0;      // status errors sent for garbage
  uint64_t messages_sent = 0;
  uint64_t messages_dropped = 0;   // a client's queue was full
};

class FoxgloveServer {
 public:
  // Listens on address:port (port 0: any free port, see port()); admits a connection only as
  // `access` allows (origin, token) and shows it only the channels of its grant's robots. Throws
  // std::runtime_error when it cannot listen.
  FoxgloveServer(const std::string& name, const std::string& address, uint16_t port, const ServerLimits& limits,
                 AccessPolicy access = {});
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  uint16_t port() const;

  // Adds a channel of `robot` (JSON encoding, jsonschema) and advertises it to the clients whose
  // grant sees that robot. latched: the last message is kept and sent to each new subscriber (maps,
  // grids, status). Returns its id, or 0 when max_channels is reached. Thread-safe.
  uint32_t add_channel(const std::string& robot, const std::string& topic, const std::string& schema_name,
                       const std::string& json_schema, bool latched);
  // True when some client subscribes to the channel (cheap: callers skip converting otherwise).
  bool subscribed(uint32_t channel) const;
  // Sends payload (JSON text) to every subscriber of the channel, stamped log_time_ns. Thread-safe;
  // the sending happens on the server's thread.
  void publish(uint32_t channel, uint64_t log_time_ns, std::string payload);

  ServerCounters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locd::view
