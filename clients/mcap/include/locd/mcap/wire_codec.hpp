// locd's DDS topics as an MCAP recording sees them: every topic with its IDL type, QoS and
// direction; the OMG IDL text (idl/locd.idl, compiled in) every schema carries; and CDR
// encoding/decoding of samples with Cyclone's own serializer, bytes exactly as they travel on DDS
// (a 4-byte encapsulation header, then XCDR1). Decoding checks the bytes against the type
// (Cyclone's normalizer: every string and sequence length against its bound and the bytes
// present) before anything is allocated.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "locd/dds/dds.hpp"

namespace locd::mcap {

// One locd topic. Per-robot topics travel in robot.<robot_id>; server_info in the default partition.
struct TopicInfo {
  const char* topic;      // DDS topic name, e.g. "locd/pose"
  const char* type_name;  // IDL name, e.g. "locd::msg::PoseEstimate" (the MCAP schema name)
  const dds_topic_descriptor_t* descriptor;
  bool per_robot;
  bool transient_local;   // state topics: a late reader gets the last sample per instance
  bool robot_input;       // robot -> locd (sensors, requests, initial pose): what a replay feeds
  bool exclusive = false; // a server's output with exclusive ownership (dds.hpp): its readers must say so
};

const std::vector<TopicInfo>& locd_topics();
const TopicInfo* find_topic(const std::string& dds_topic);

// The text of idl/locd.idl, the schema data of every locd channel (schema encoding "omgidl").
const std::string& locd_idl();

// The recording layout: schema encoding, message encoding, channel topic and metadata keys.
inline constexpr const char* kSchemaEncoding = "omgidl";
inline constexpr const char* kMessageEncoding = "cdr";
inline constexpr const char* kMetaDdsTopic = "dds_topic";
inline constexpr const char* kMetaPartition = "partition";
inline constexpr const char* kMetaRobotId = "robot_id";
// "<robot_id>/<dds topic>" for per-robot topics, the DDS topic otherwise.
std::string channel_topic(const TopicInfo& topic, const std::string& robot_id);

// Serializes a sample of `descriptor`'s type: encapsulation header (CDR, little endian) + XCDR1.
std::vector<uint8_t> encode(const dds_topic_descriptor_t& descriptor, const void* sample);
template <typename T>
std::vector<uint8_t> encode(const T& sample) { return encode(dds::descriptor<T>(), &sample); }

// A decoded sample, freed with dds_sample_free.
struct SampleDeleter {
  const dds_topic_descriptor_t* descriptor;
  void operator()(void* sample) const;
};
using SamplePtr = std::unique_ptr<void, SampleDeleter>;

// Decodes CDR bytes (header + payload; XCDR1 or XCDR2, either byte order). Throws
// std::invalid_argument naming the type and the cause when the bytes do not hold a valid sample.
SamplePtr decode(const dds_topic_descriptor_t& descriptor, const uint8_t* data, size_t size);

// The robot_id (first member of every per-robot type) read from CDR bytes without decoding the
// rest; empty when the bytes are too short or the string is malformed.
std::string robot_id_of(const uint8_t* data, size_t size);

}  // namespace locd::mcap
