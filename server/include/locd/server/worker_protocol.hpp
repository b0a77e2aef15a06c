// The channel between locd and a plugin worker process (locd-worker): length-prefixed frames on a
// Unix stream socket. The server sends requests for plugin instances; the worker answers each
// request with exactly one reply, in the order it received them, and may send log lines in
// between. A worker is trusted no more than the network: every size read from it is bounded
// before anything is allocated, and a frame that does not decode is a protocol error that costs
// the worker (never the server).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "locd/sdk/plugin.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/types.hpp"

namespace locd::server::worker {

// A frame that breaks the protocol (bad magic, unknown op, a size beyond its bound, truncated).
class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Op : uint32_t {
  // server -> worker, each answered by one kReply
  kConfigure = 1,  // create an instance of the worker's plugin and configure it
  kSetPose = 2,
  kUpdate = 3,
  kSaveMap = 4,
  kRelease = 5,  // destroy the instance
  // worker -> server
  kReply = 100,
  kLog = 101,
};
const char* op_name(Op op);

constexpr uint32_t kFrameMagic = 0x4c4f4344;  // "LOCD"

// Exit codes of locd-worker besides 0 (the server closed the channel) and a plugin's own.
constexpr int kExitOutOfMemory = 86;  // an allocation failed (memory_limit_mb reached)
constexpr int kExitCannotStart = 87;  // bad arguments, or the plugin library would not load
constexpr int kExitChannelLost = 88;  // the channel broke or sent a malformed frame

// Every frame starts with this header; `instance` names the plugin instance it concerns and
// `length` the payload bytes that follow.
struct FrameHeader {
  uint32_t magic = kFrameMagic;
  uint32_t op = 0;
  uint64_t instance = 0;
  uint64_t length = 0;
};
constexpr size_t kFrameHeaderBytes = sizeof(FrameHeader);
static_assert(kFrameHeaderBytes == 24);

// The largest payload either side accepts: room for the largest map or grid the limits allow.
uint64_t max_payload_bytes(const Limits& limits);

// How a request went. kInputError: the plugin refused one message (InputError), the session
// counts it as rejected; kConfigError: configure refused the config; kPluginError: any other
// exception (the plugin failed, the session reports it and goes on).
enum class Outcome : uint8_t { kOk = 0, kInputError = 1, kConfigError = 2, kPluginError = 3 };

struct ConfigureRequest {
  std::string robot_id;
  Limits limits;
  std::vector<std::string> map_directories;
  std::string output_directory;
  PluginConfigText config;
};

struct Reply {
  Op request = Op::kReply;  // the op answered
  Outcome outcome = Outcome::kOk;
  std::string message;      // the error, or what save_map wrote
  double compute_ms = 0.0;  // time the plugin took
  UpdateResult result;      // update: the outputs; configure: the initial outputs
};

struct LogLine {
  LogLevel level = LogLevel::kInfo;
  std::string text;
};

// Appends one whole frame (header and payload) to `out`.
void append_configure(std::string& out, uint64_t instance, const ConfigureRequest& request);
void append_set_pose(std::string& out, uint64_t instance, const PoseEstimate& pose);
void append_update(std::string& out, uint64_t instance, const Measurement& measurement);
void append_request(std::string& out, uint64_t instance, Op op);  // kSaveMap, kRelease: no payload
void append_reply(std::string& out, uint64_t instance, const Reply& reply);
void append_log(std::string& out, uint64_t instance, const LogLine& line);

// Reads a header from the first kFrameHeaderBytes of `bytes`; ProtocolError unless its magic and
// op are known and its length is within `max_payload`.
FrameHeader parse_header(const char* bytes, uint64_t max_payload);

// Payload decoders; every count is checked against `limits` (and the bytes left) before any
// allocation. ProtocolError on anything malformed.
ConfigureRequest decode_configure(std::string_view payload, const Limits& limits);
PoseEstimate decode_set_pose(std::string_view payload);
Measurement decode_update(std::string_view payload, const Limits& limits);
Reply decode_reply(std::string_view payload, const Limits& limits);
LogLine decode_log(std::string_view payload);

}  // namespace locd::server::worker
