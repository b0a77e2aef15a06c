#include "locd/mcap/locd_writer.hpp"

#include "locd/dds/topics.hpp"

namespace locd::mcap {

void LocdWriter::write(const TopicInfo& topic, const std::string& robot_id, uint64_t log_time, uint64_t publish_time,
                       const uint8_t* data, size_t size) {
  auto key = std::make_pair(&topic, robot_id);
  auto channel = channel_ids_.find(key);
  if (channel == channel_ids_.end()) {
    auto schema = schema_ids_.find(topic.type_name);
    if (schema == schema_ids_.end()) {
      schema = schema_ids_.emplace(topic.type_name, writer_.add_schema(topic.type_name, kSchemaEncoding, locd_idl())).first;
    }
    Metadata metadata{{kMetaDdsTopic, topic.topic}, {kMetaPartition, ""}};
    if (topic.per_robot) {
      metadata[kMetaRobotId] = robot_id;
      metadata[kMetaPartition] = topics::robot_partition(robot_id);
    }
    channel = channel_ids_.emplace(key, writer_.add_channel(schema->second, channel_topic(topic, robot_id),
                                                            kMessageEncoding, metadata)).first;
  }
  writer_.write(channel->second, log_time, publish_time, data, size);
}

}  // namespace locd::mcap
