#include "locd/dds/dds.hpp"

#include <cstdlib>

namespace locd::dds {

Error::Error(const std::string& what, dds_return_t code) : std::runtime_error(what), code_(code) {}

dds_return_t check(dds_return_t rc, const char* what) {
  if (rc == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) {
    throw Error(std::string(what) + ": not allowed by DDS Security: this participant's signed permissions do not grant it",
                rc);
  }
  if (rc < 0) throw Error(std::string(what) + ": " + dds_strretcode(rc), rc);
  return rc;
}

void Entity::reset() {
  if (handle_ > 0) dds_delete(handle_);
  handle_ = 0;
}

namespace {

// Cyclone announces the process name, pid and host name of every participant in its discovery
// data, in clear even with DDS Security (participant discovery is not protected). Empty values
// in the participant's own QoS take their place. The host name also travels in Cyclone's
// version information of the same message, which no setting of this Cyclone (0.10) removes.
std::unique_ptr<dds_qos_t, QosDeleter> participant_qos() {
  std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
  for (const char* property : {"__ProcessName", "__Pid", "__Hostname"}) dds_qset_prop(qos.get(), property, "");
  return qos;
}

}  // namespace

Participant::Participant(dds_domainid_t domain)
    : Entity(check(dds_create_participant(domain, participant_qos().get(), nullptr),
                   ("create participant on domain " + std::to_string(domain) +
                    " (CYCLONEDDS_URI=" + config_uri() + ")").c_str())) {}

std::unique_ptr<dds_qos_t, QosDeleter> make_qos(QosProfile profile, int depth) {
  std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  const dds_data_representation_id_t xcdr1[] = {DDS_DATA_REPRESENTATION_XCDR1};
  dds_qset_data_representation(qos.get(), 1, xcdr1);
  // A writer going away unregisters its instances without disposing them: a reader then sees
  // NOT_ALIVE_NO_WRITERS only once the last writer of an instance is gone (session ownership).
  dds_qset_writer_data_lifecycle(qos.get(), false);
  switch (profile) {
    case QosProfile::kSensor:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      break;
    case QosProfile::kPose:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
      break;
    case QosProfile::kOutput:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      break;
    case QosProfile::kState:
    case QosProfile::kOutputState:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
    case QosProfile::kRos2Latched:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
    case QosProfile::kRos2Rosout:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_lifespan(qos.get(), DDS_SECS(10));
      break;
    case QosProfile::kRos2SensorData:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      break;
    case QosProfile::kRos2Default:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      break;
  }
  if (exclusive_ownership(profile)) dds_qset_ownership(qos.get(), DDS_OWNERSHIP_EXCLUSIVE);
  return qos;
}

bool exclusive_ownership(QosProfile profile) {
  return profile == QosProfile::kPose || profile == QosProfile::kOutput || profile == QosProfile::kOutputState;
}

dds_entity_t create_topic(const Participant& p, const dds_topic_descriptor_t& d, const std::string& name) {
  return check(dds_create_topic(p.handle(), &d, name.c_str(), nullptr, nullptr), ("create topic " + name).c_str());
}

std::string config_uri() {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  return uri ? uri : "";
}

}  // namespace locd::dds

namespace locd::dds {
namespace {

std::unique_ptr<dds_qos_t, QosDeleter> partition_qos(const Partitions& partitions) {
  std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
  std::vector<const char*> names;
  names.reserve(partitions.size());
  for (const auto& p : partitions) names.push_back(p.c_str());
  dds_qset_partition(qos.get(), static_cast<uint32_t>(names.size()), names.data());
  return qos;
}

}  // namespace

Entity publisher_for(const Participant& p, const Partitions& partitions) {
  if (partitions.empty()) return Entity();
  auto qos = partition_qos(partitions);
  return Entity(check(dds_create_publisher(p.handle(), qos.get(), nullptr), "create publisher"));
}

Entity subscriber_for(const Participant& p, const Partitions& partitions) {
  if (partitions.empty()) return Entity();
  auto qos = partition_qos(partitions);
  return Entity(check(dds_create_subscriber(p.handle(), qos.get(), nullptr), "create subscriber"));
}

std::string endpoint_text(const std::string& topic, const Partitions& partitions) {
  std::string names;
  for (const auto& p : partitions) names += (names.empty() ? "" : ", ") + p;
  return topic + " in partition " + (partitions.empty() ? std::string("(default)") : "[" + names + "]");
}

WriterInfo writer_info(dds_entity_t reader, dds_instance_handle_t publication) {
  WriterInfo out;
  dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(reader, publication);
  if (!endpoint) return out;
  uint32_t n = 0;
  char** names = nullptr;
  if (endpoint->qos && dds_qget_partition(endpoint->qos, &n, &names)) {
    for (uint32_t i = 0; i < n; ++i) {
      out.partitions.emplace_back(names[i]);
      dds_free(names[i]);
    }
    dds_free(names);
  }
  static constexpr char kHex[] = "0123456789abcdef";
  for (const uint8_t byte : endpoint->participant_key.v) {
    out.participant += kHex[byte >> 4];
    out.participant += kHex[byte & 15];
  }
  dds_builtintopic_free_endpoint(endpoint);
  return out;
}

}  // namespace locd::dds
