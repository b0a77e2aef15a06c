// An MCAP writer laid out for locd samples: one schema per IDL type (the whole locd.idl, encoding
// omgidl), one channel per (topic, robot) named "<robot_id>/<topic>" with the DDS topic, partition
// and robot in its metadata, messages as CDR. The recorder and `locsim run --mcap` write through
// it, and `locsim replay` reads that layout back.
#pragma once

#include <map>
#include <string>
#include <utility>

#include "locd/mcap/mcap.hpp"
#include "locd/mcap/wire_codec.hpp"

namespace locd::mcap {

class LocdWriter {
 public:
  LocdWriter(const std::string& path, const WriterOptions& options) : writer_(path, options) {}

  // CDR bytes (header included) of `topic`'s type for `robot_id` ("" for server_info).
  void write(const TopicInfo& topic, const std::string& robot_id, uint64_t log_time, uint64_t publish_time,
             const uint8_t* data, size_t size);
  // Encodes a wire sample of the topic's type and writes it.
  template <typename T>
  void write_sample(const char* dds_topic, const std::string& robot_id, uint64_t log_time, const T& sample) {
    const auto bytes = encode(sample);
    write(*find_topic(dds_topic), robot_id, log_time, log_time, bytes.data(), bytes.size());
  }

  Writer& writer() { return writer_; }

 private:
  Writer writer_;
  std::map<std::string, uint16_t> schema_ids_;                                // type name -> schema
  std::map<std::pair<const TopicInfo*, std::string>, uint16_t> channel_ids_;  // (topic, robot) -> channel
};

}  // namespace locd::mcap
