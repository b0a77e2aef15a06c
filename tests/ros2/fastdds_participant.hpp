// A Fast DDS 2.9 participant for the tests that play another vendor's program or a ROS 2 stack
// against locd (no Cyclone DDS and no locd code): typed writers and readers on the types fastddsgen
// generates from idl/locd.idl and idl/ros2.idl, and every endpoint discovery shows, as rmw's graph
// cache sees them.
//
// Fast DDS finds Cyclone on one host with 127.0.0.1 as its initial peer over UDPv4 (no shared
// memory, which Cyclone does not speak), as notes/dds.md says.
#pragma once

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include "ros2.h"  // fastddsgen's, from idl/ros2.idl

namespace locd::test {

namespace fdds = eprosima::fastdds::dds;
using Guid = std::array<uint8_t, 16>;

struct FastQos {
  bool reliable = true;
  bool transient_local = false;
  int depth = 10;
  bool exclusive = false;  // exclusive ownership, as locd's per-robot outputs (pose, maps, diagnostics) need
};

class FastDds {
 public:
  explicit FastDds(int domain) {
    fdds::DomainParticipantQos qos;
    qos.name("locd_fastdds_test");
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.push_back("127.0.0.1");
    qos.transport().user_transports.push_back(udp);
    qos.transport().use_builtin_transports = false;
    eprosima::fastrtps::rtps::Locator_t peer;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, "127.0.0.1");
    qos.wire_protocol().builtin.initialPeersList.push_back(peer);
    participant_ = fdds::DomainParticipantFactory::get_instance()->create_participant(domain, qos, &discovery_);
  }
  ~FastDds() {
    if (!participant_) return;
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  FastDds(const FastDds&) = delete;
  FastDds& operator=(const FastDds&) = delete;
  bool ok() const { return participant_ != nullptr; }

  // A writer (reader) of `PubSubType` on `topic` in `partition` ("" = the default partition).
  template <typename PubSubType>
  fdds::DataWriter* writer(const std::string& topic, const std::string& partition, FastQos qos) {
    fdds::PublisherQos pq;
    if (!partition.empty()) pq.partition().push_back(partition.c_str());
    fdds::Publisher* publisher = participant_->create_publisher(pq);
    return publisher->create_datawriter(topic_of<PubSubType>(topic), endpoint_qos<fdds::DataWriterQos>(qos));
  }
  template <typename PubSubType>
  fdds::DataReader* reader(const std::string& topic, const std::string& partition, FastQos qos) {
    fdds::SubscriberQos sq;
    if (!partition.empty()) sq.partition().push_back(partition.c_str());
    fdds::Subscriber* subscriber = participant_->create_subscriber(sq);
    return subscriber->create_datareader(topic_of<PubSubType>(topic), endpoint_qos<fdds::DataReaderQos>(qos));
  }

  // The GUIDs of the writers (readers) discovery has shown on `topic`, this participant's too.
  std::set<Guid> writers_on(const std::string& topic) const { return discovery_.on(topic, true); }
  std::set<Guid> readers_on(const std::string& topic) const { return discovery_.on(topic, false); }

 private:
  class Discovery : public fdds::DomainParticipantListener {
   public:
    void on_publisher_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
      const bool gone = info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER &&
                        info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::CHANGED_QOS_WRITER;
      note(info.info.topicName().to_string(), info.info.guid(), true, gone);
    }
    void on_subscriber_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::ReaderDiscoveryInfo&& info) override {
      const bool gone = info.status != eprosima::fastrtps::rtps::ReaderDiscoveryInfo::DISCOVERED_READER &&
                        info.status != eprosima::fastrtps::rtps::ReaderDiscoveryInfo::CHANGED_QOS_READER;
      note(info.info.topicName().to_string(), info.info.guid(), false, gone);
    }
    std::set<Guid> on(const std::string& topic, bool writers) const {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = endpoints_.find({topic, writers});
      return it == endpoints_.end() ? std::set<Guid>{} : it->second;
    }

   private:
    void note(const std::string& topic, const eprosima::fastrtps::rtps::GUID_t& guid, bool writer, bool gone) {
      Guid g{};
      std::copy(guid.guidPrefix.value, guid.guidPrefix.value + 12, g.begin());
      std::copy(guid.entityId.value, guid.entityId.value + 4, g.begin() + 12);
      std::lock_guard<std::mutex> lock(mutex_);
      auto& set = endpoints_[{topic, writer}];
      if (gone) set.erase(g);
      else set.insert(g);
    }
    mutable std::mutex mutex_;
    std::map<std::pair<std::string, bool>, std::set<Guid>> endpoints_;
  };

  template <typename Qos>
  static Qos endpoint_qos(FastQos wanted) {
    Qos q;
    q.reliability().kind = wanted.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
    q.durability().kind = wanted.transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
    q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    q.history().depth = wanted.depth;
    if (wanted.exclusive) q.ownership().kind = fdds::EXCLUSIVE_OWNERSHIP_QOS;
    q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_RESERVE_MEMORY_MODE;
    return q;
  }
  template <typename PubSubType>
  fdds::Topic* topic_of(const std::string& name) {
    fdds::TypeSupport type(new PubSubType());
    type.register_type(participant_);
    if (auto* existing = participant_->find_topic(name, eprosima::fastrtps::Duration_t(0, 0))) return existing;
    return participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  }

  Discovery discovery_;  // before the participant, which calls it until deleted
  fdds::DomainParticipant* participant_ = nullptr;
};

inline bool matched(fdds::DataWriter* w) {
  fdds::PublicationMatchedStatus s;
  w->get_publication_matched_status(s);
  return s.current_count > 0;
}

// Every sample the reader has now, to `visit`.
template <typename T, typename Visit>
void take_all(fdds::DataReader* reader, Visit visit) {
  T sample;
  fdds::SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
    if (info.valid_data) visit(sample);
  }
}

// A pose into either IDL's pose type (locd's Pose3D, ROS 2's Pose_): the same members.
template <typename FastPose>
void to_fast(const Eigen::Isometry3d& T, FastPose& out) {
  const Eigen::Quaterniond q(T.linear());
  out.position().x(T.translation().x());
  out.position().y(T.translation().y());
  out.position().z(T.translation().z());
  out.orientation().x(q.x());
  out.orientation().y(q.y());
  out.orientation().z(q.z());
  out.orientation().w(q.w());
}

inline void to_fast(int64_t stamp_ns, const std::string& frame, std_msgs::msg::dds_::Header_& out) {
  out.stamp().sec(static_cast<int32_t>(stamp_ns / 1'000'000'000));
  out.stamp().nanosec(static_cast<uint32_t>(stamp_ns % 1'000'000'000));
  out.frame_id() = frame;
}

inline int64_t from_fast(const builtin_interfaces::msg::dds_::Time_& t) {
  return int64_t{t.sec()} * 1'000'000'000 + t.nanosec();
}

inline Eigen::Isometry3d from_fast(const geometry_msgs::msg::dds_::Transform_& t) {
  const auto& r = t.rotation();
  return Eigen::Translation3d(t.translation().x(), t.translation().y(), t.translation().z()) *
         Eigen::Quaterniond(r.w(), r.x(), r.y(), r.z());
}

inline int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace locd::test
