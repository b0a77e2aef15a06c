#include "ws_server.hpp"

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "locd/sdk/text.hpp"

namespace locd::view {
namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Handle = websocketpp::connection_hdl;
using Json = nlohmann::json;

constexpr const char* kSubprotocol = "foxglove.websocket.v1";
enum StatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

// Client text in a status or log line: escaped and cut.
std::string quoted(const std::string& s) {
  return "'" + escaped(s.size() > 64 ? s.substr(0, 64) + "..." : s) + "'";
}

}  // namespace

struct FoxgloveServer::Impl {
  struct Channel {
    std::string robot, topic, schema_name, schema;
    bool latched = false;
    bool has_last = false;
    uint64_t last_time = 0;
    std::shared_ptr<const std::string> last;
  };
  struct Client {
    std::map<uint32_t, uint32_t> channel_of;  // subscription -> channel
    uint32_t advertised = 0;                   // channels 1..advertised were considered for it
    const Grant* grant = nullptr;              // what its token lets it see (nullptr: no token asked)
    bool open = false;
    bool warned_drop = false;
  };

  std::string name;
  ServerLimits limits;
  AccessPolicy access;
  WsServer ws;
  std::thread thread;

  mutable std::mutex mutex;       // channels
  std::vector<Channel> channels;  // id = index + 1
  std::unique_ptr<std::atomic<int>[]> subscriber_count;

  // Server thread only.
  std::map<Handle, Client, std::owner_less<Handle>> clients;
  std::vector<std::vector<std::pair<Handle, uint32_t>>> subscribers;  // by channel id

  std::atomic<uint64_t> refused{0}, errors{0}, sent{0}, dropped{0}, connected{0};
  // Log lines: at most 5 a second per kind (client errors, refused clients).
  enum LogKind { kClientError, kRefusal, kLogKinds };
  std::chrono::steady_clock::time_point log_window[kLogKinds];
  int logged_in_window[kLogKinds] = {};

  Impl(const std::string& n, const ServerLimits& l, AccessPolicy a) : name(n), limits(l), access(std::move(a)) {
    subscriber_count.reset(new std::atomic<int>[limits.max_channels + 1]);
    for (size_t i = 0; i <= limits.max_channels; ++i) subscriber_count[i] = 0;
  }

  void log(LogKind kind, const std::string& line) {
    const auto now = std::chrono::steady_clock::now();
    if (now - log_window[kind] > std::chrono::seconds(1)) {
      log_window[kind] = now;
      logged_in_window[kind] = 0;
    }
    if (++logged_in_window[kind] <= 5) std::cerr << "locview: " << line << std::endl;
  }

  void send_text(Handle h, const Json& message) {
    websocketpp::lib::error_code ec;
    ws.send(h, message.dump(), websocketpp::frame::opcode::text, ec);
  }

  void status(Handle h, StatusLevel level, const std::string& message) {
    if (level == kError) {
      ++errors;
      log(kClientError, "client error: " + message);
    }
    send_text(h, {{"op", "status"}, {"level", level}, {"message", message}});
  }

  Json channel_json(uint32_t id, const Channel& c) const {
    return {{"id", id}, {"topic", c.topic}, {"encoding", "json"}, {"schemaName", c.schema_name},
            {"schema", c.schema}, {"schemaEncoding", "jsonschema"}};
  }

  static bool visible(const Client& client, const Channel& channel) {
    return !client.grant || client.grant->sees(channel.robot);
  }

  // Advertises the channels a client has not seen yet, of the robots it may see.
  void advertise_new(Handle h, Client& client) {
    Json list = Json::array();
    {
      std::lock_guard<std::mutex> lock(mutex);
      for (uint32_t id = client.advertised + 1; id <= channels.size(); ++id) {
        if (visible(client, channels[id - 1])) list.push_back(channel_json(id, channels[id - 1]));
      }
      client.advertised = static_cast<uint32_t>(channels.size());
    }
    if (!list.empty()) send_text(h, {{"op", "advertise"}, {"channels", list}});
  }

  bool validate(Handle h) {
    WsServer::connection_ptr con = ws.get_con_from_hdl(h);
    const auto& requested = con->get_requested_subprotocols();
    if (std::find(requested.begin(), requested.end(), kSubprotocol) == requested.end()) {
      ++refused;
      con->set_status(websocketpp::http::status_code::bad_request);
      con->set_body(std::string("locview speaks the WebSocket subprotocol ") + kSubprotocol + " only\n");
      return false;
    }
    const Admission admission = admit(access, con->get_request_header("Authorization"), con->get_resource(),
                                      con->get_request_header("Origin"));
    if (!admission.admitted) {
      ++refused;
      con->set_status(static_cast<websocketpp::http::status_code::value>(admission.http_status));
      con->set_body("locview: " + admission.reason + "\n");
      log(kRefusal, "refused a client from " + escaped(con->get_remote_endpoint()) + ": " + admission.reason);
      return false;
    }
    if (clients.size() >= limits.max_clients) {
      ++refused;
      con->set_status(websocketpp::http::status_code::service_unavailable);
      con->set_body("locview: " + std::to_string(clients.size()) + " clients are connected, the most it serves (--max-clients)\n");
      log(kRefusal, "refused a client: " + std::to_string(clients.size()) + " connected (--max-clients " +
          std::to_string(limits.max_clients) + ")");
      return false;
    }
    con->select_subprotocol(kSubprotocol);
    con->set_max_message_size(limits.max_client_message_bytes);
    clients[h].grant = admission.grant;  // counts against max_clients from now on
    return true;
  }

  void on_open(Handle h) {
    Client& client = clients[h];
    client.open = true;
    ++connected;
    std::random_device rd;
    send_text(h, {{"op", "serverInfo"}, {"name", name}, {"capabilities", Json::array()},
                  {"supportedEncodings", Json::array()}, {"metadata", Json::object()},
                  {"sessionId", std::to_string(rd())}});
    advertise_new(h, client);
  }

  void on_close(Handle h) {
    auto it = clients.find(h);
    if (it == clients.end()) return;
    if (it->second.open) --connected;
    for (const auto& [subscription, channel] : it->second.channel_of) remove_subscriber(h, channel);
    clients.erase(it);
  }

  void remove_subscriber(Handle h, uint32_t channel) {
    auto& list = subscribers[channel];
    for (auto s = list.begin(); s != list.end(); ++s) {
      if (!s->first.owner_before(h) && !h.owner_before(s->first)) {
        list.erase(s);
        --subscriber_count[channel];
        return;
      }
    }
  }

  void on_message(Handle h, WsServer::message_ptr message) {
    auto it = clients.find(h);
    if (it == clients.end()) return;
    if (message->get_opcode() != websocketpp::frame::opcode::text) {
      status(h, kError, "binary messages from clients are not supported (locview advertises no clientPublish capability)");
      return;
    }
    Json request;
    try {
      request = Json::parse(message->get_payload());
    } catch (const std::exception&) {
      status(h, kError, "message is not JSON: " + quoted(message->get_payload()));
      return;
    }
    if (!request.is_object() || !request.contains("op") || !request["op"].is_string()) {
      status(h, kError, "message is not a JSON object with a string 'op': " + quoted(message->get_payload()));
      return;
    }
    const std::string op = request["op"];
    if (op == "subscribe") {
      subscribe(h, it->second, request);
    } else if (op == "unsubscribe") {
      unsubscribe(h, it->second, request);
    } else {
      status(h, kError, "op " + quoted(op) + " is not supported; locview serves subscribe and unsubscribe");
    }
  }

  static bool is_id(const Json& j) { return j.is_number_unsigned() && j.get<uint64_t>() <= 0xffffffffu; }

  void subscribe(Handle h, Client& client, const Json& request) {
    if (!request.contains("subscriptions") || !request["subscriptions"].is_array()) {
      status(h, kError, "subscribe needs an array 'subscriptions' of {id, channelId}");
      return;
    }
    for (const Json& s : request["subscriptions"]) {
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !is_id(s["id"]) || !is_id(s["channelId"])) {
        status(h, kError, "subscription " + quoted(s.dump()) + " needs unsigned 32-bit 'id' and 'channelId'");
        continue;
      }
      const uint32_t id = s["id"], channel = s["channelId"];
      bool shown = false;
      if (channel != 0 && channel <= client.advertised) {
        std::lock_guard<std::mutex> lock(mutex);
        shown = visible(client, channels[channel - 1]);
      }
      if (!shown) {
        status(h, kError, "channel " + std::to_string(channel) + " is not advertised (subscription " + std::to_string(id) + ")");
        continue;
      }
      if (client.channel_of.count(id)) {
        status(h, kError, "subscription id " + std::to_string(id) + " is in use; unsubscribe it first");
        continue;
      }
      bool already = false;
      for (const auto& [sub, ch] : client.channel_of) already = already || ch == channel;
      if (already) {
        status(h, kError, "channel " + std::to_string(channel) + " is subscribed already (one subscription per channel)");
        continue;
      }
      if (client.channel_of.size() >= limits.max_subscriptions_per_client) {
        status(h, kError, "more than " + std::to_string(limits.max_subscriptions_per_client) + " subscriptions; unsubscribe some first");
        continue;
      }
      client.channel_of[id] = channel;
      if (subscribers.size() <= channel) subscribers.resize(channel + 1);
      subscribers[channel].emplace_back(h, id);
      ++subscriber_count[channel];
      std::shared_ptr<const std::string> last;
      uint64_t last_time = 0;
      {
        std::lock_guard<std::mutex> lock(mutex);
        const Channel& c = channels[channel - 1];
        if (c.latched && c.has_last) {
          last = c.last;
          last_time = c.last_time;
        }
      }
      if (last) send_data(h, client, id, last_time, *last);
    }
  }

  void unsubscribe(Handle h, Client& client, const Json& request) {
    if (!request.contains("subscriptionIds") || !request["subscriptionIds"].is_array()) {
      status(h, kError, "unsubscribe needs an array 'subscriptionIds'");
      return;
    }
    for (const Json& id : request["subscriptionIds"]) {
      if (!is_id(id) || !client.channel_of.count(id.get<uint32_t>())) {
        status(h, kError, "no subscription " + quoted(id.dump()) + " to unsubscribe");
        continue;
      }
      const uint32_t channel = client.channel_of[id.get<uint32_t>()];
      client.channel_of.erase(id.get<uint32_t>());
      remove_subscriber(h, channel);
    }
  }

  void send_data(Handle h, Client& client, uint32_t subscription, uint64_t time, const std::string& payload) {
    websocketpp::lib::error_code ec;
    WsServer::connection_ptr con = ws.get_con_from_hdl(h, ec);
    if (ec || con->get_state() != websocketpp::session::state::open) return;
    if (con->get_buffered_amount() + payload.size() > limits.max_queued_bytes_per_client) {
      ++dropped;
      if (!client.warned_drop) {
        client.warned_drop = true;
        status(h, kWarning, "messages dropped: this client reads slower than the fleet publishes (more than " +
                                std::to_string(limits.max_queued_bytes_per_client) + " bytes queued)");
      }
      return;
    }
    std::string frame(1 + 4 + 8, '\0');
    frame[0] = 0x01;  // Message Data
    for (int i = 0; i < 4; ++i) frame[1 + i] = static_cast<char>((subscription >> (8 * i)) & 0xff);
    for (int i = 0; i < 8; ++i) frame[5 + i] = static_cast<char>((time >> (8 * i)) & 0xff);
    frame += payload;
    ws.send(h, frame, websocketpp::frame::opcode::binary, ec);
    if (!ec) ++sent;
  }

  void deliver(uint32_t channel, uint64_t time, const std::shared_ptr<const std::string>& payload) {
    if (channel >= subscribers.size()) return;
    for (const auto& [h, subscription] : subscribers[channel]) {
      auto it = clients.find(h);
      if (it != clients.end()) send_data(h, it->second, subscription, time, *payload);
    }
  }
};

FoxgloveServer::FoxgloveServer(const std::string& name, const std::string& address, uint16_t port,
                               const ServerLimits& limits, AccessPolicy access)
    : impl_(std::make_unique<Impl>(name, limits, std::move(access))) {
  Impl& s = *impl_;
  s.ws.clear_access_channels(websocketpp::log::alevel::all);
  s.ws.clear_error_channels(websocketpp::log::elevel::all);
  s.ws.init_asio();
  s.ws.set_reuse_addr(true);
  s.ws.set_validate_handler([&s](Handle h) { return s.validate(h); });
  s.ws.set_open_handler([&s](Handle h) { s.on_open(h); });
  s.ws.set_close_handler([&s](Handle h) { s.on_close(h); });
  s.ws.set_fail_handler([&s](Handle h) { s.on_close(h); });
  s.ws.set_message_handler([&s](Handle h, WsServer::message_ptr m) { s.on_message(h, m); });
  s.ws.set_http_handler([&s](Handle h) {
    WsServer::connection_ptr con = s.ws.get_con_from_hdl(h);
    con->set_status(websocketpp::http::status_code::upgrade_required);
    con->set_body(std::string("locview: a Foxglove WebSocket server; connect Foxglove to ws://<host>:<port> (") +
                  kSubprotocol + ")\n");
  });
  websocketpp::lib::error_code ec;
  s.ws.listen(address, std::to_string(port), ec);
  if (ec) throw std::runtime_error("locview cannot listen on " + address + ":" + std::to_string(port) + ": " + ec.message());
  s.ws.start_accept(ec);
  if (ec) throw std::runtime_error("locview cannot accept on port " + std::to_string(port) + ": " + ec.message());
  s.thread = std::thread([&s] {
    for (;;) {
      try {
        s.ws.run();
        return;
      } catch (const std::exception& e) {  // a handler threw: say so and keep serving
        std::cerr << "locview: " << e.what() << std::endl;
      }
    }
  });
}

FoxgloveServer::~FoxgloveServer() {
  Impl& s = *impl_;
  websocketpp::lib::error_code ec;
  s.ws.stop_listening(ec);
  s.ws.stop();
  if (s.thread.joinable()) s.thread.join();
}

uint16_t FoxgloveServer::port() const {
  websocketpp::lib::asio::error_code ec;
  return impl_->ws.get_local_endpoint(ec).port();
}

uint32_t FoxgloveServer::add_channel(const std::string& robot, const std::string& topic, const std::string& schema_name,
                                     const std::string& json_schema, bool latched) {
  Impl& s = *impl_;
  uint32_t id = 0;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (s.channels.size() >= s.limits.max_channels) return 0;
    s.channels.push_back({robot, topic, schema_name, json_schema, latched, false, 0, nullptr});
    id = static_cast<uint32_t>(s.channels.size());
  }
  s.ws.get_io_service().post([&s] {
    for (auto& [h, client] : s.clients) {
      if (client.open) s.advertise_new(h, client);
    }
  });
  return id;
}

bool FoxgloveServer::subscribed(uint32_t channel) const {
  return channel > 0 && channel <= impl_->limits.max_channels && impl_->subscriber_count[channel] > 0;
}

void FoxgloveServer::publish(uint32_t channel, uint64_t log_time_ns, std::string payload) {
  Impl& s = *impl_;
  auto shared = std::make_shared<const std::string>(std::move(payload));
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (channel == 0 || channel > s.channels.size()) return;
    Impl::Channel& c = s.channels[channel - 1];
    if (c.latched) {
      c.last = shared;
      c.last_time = log_time_ns;
      c.has_last = true;
    }
  }
  if (!subscribed(channel)) return;
  s.ws.get_io_service().post([&s, channel, log_time_ns, shared] { s.deliver(channel, log_time_ns, shared); });
}

ServerCounters FoxgloveServer::counters() const {
  ServerCounters c;
  c.clients = impl_->connected;
  c.refused_clients = impl_->refused;
  c.client_errors = impl_->errors;
  c.messages_sent = impl_->sent;
  c.messages_dropped = impl_->dropped;
  return c;
}

}  // namespace locd::view
