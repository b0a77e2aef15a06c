// Records locd's DDS traffic into MCAP: one raw reader per locd topic (wire_codec.hpp) in the
// partitions of the robots asked for (robot.<id>, or robot.* for every robot) plus server_info,
// each sample written as the CDR bytes it travelled as, on a channel per (topic, robot).
//
// DDS listener threads only copy the bytes into a bounded queue; one writer thread turns the
// queue into chunks and closes a chunk at least every `chunk_age`, so a recorder killed at any
// moment loses at most that much. When the queue is full (the disk cannot keep up) samples are
// dropped and counted, never blocking DDS.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "locd/mcap/mcap.hpp"

namespace locd::mcap {

struct RecorderOptions {
  uint32_t domain_id = 0;
  std::vector<std::string> robots;  // empty: every robot (robot.*)
  WriterOptions writer;
  std::chrono::milliseconds chunk_age{1000};
  size_t max_queue_bytes = 256u << 20;  // samples waiting for the writer thread
  int depth = 64;                        // reader history per instance
};

struct RecorderCounts {
  uint64_t messages = 0;        // written
  uint64_t bytes = 0;           // message payload bytes written
  uint64_t dropped = 0;         // queue full
  uint64_t file_bytes = 0;      // bytes in the file so far
  std::map<std::string, uint64_t> per_topic;  // DDS topic -> messages written
  std::string error;            // the writer failed (disk full, ...): recording stopped
};

class Recorder {
 public:
  // Opens `path` and starts reading. Throws std::runtime_error (file, DDS) or
  // std::invalid_argument (a robot id that is not 1-64 characters of [A-Za-z0-9_.-]).
  Recorder(const std::string& path, const RecorderOptions& options);
  ~Recorder();  // stop()
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Stops reading, writes what is queued, closes the file (summary, footer). Idempotent.
  void stop();
  RecorderCounts counts() const;
  // Readers matched to writers (for tests and a recorder waiting for its sources).
  uint32_t matched_writers() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locd::mcap
