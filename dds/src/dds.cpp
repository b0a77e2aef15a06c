#include "locd/dds/dds.hpp"

#include <cstdlib>

namespace locd::dds {

Error::Error(const std::string& what, dds_return_t code) : std::runtime_error(what), code_(code) {}

dds_return_t check(dds_return_t rc, const char* what) {
  if (rc < 0) throw Error(std::string(what) + ": " + dds_strretcode(rc), rc);
  return rc;
}

void Entity::reset() {
  if (handle_ > 0) dds_delete(handle_);
  handle_ = 0;
}

Participant::Participant(dds_domainid_t domain)
    : Entity(check(dds_create_participant(domain, nullptr, nullptr),
                   ("create participant on domain " + std::to_string(domain) +
                    " (CYCLONEDDS_URI=" + config_uri() + ")").c_str())) {}

std::unique_ptr<dds_qos_t, QosDeleter> make_qos(QosProfile profile, int depth) {
  std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  const dds_data_representation_id_t xcdr1[] = {DDS_DATA_REPRESENTATION_XCDR1};
  dds_qset_data_representation(qos.get(), 1, xcdr1);
  switch (profile) {
    case QosProfile::kSensor:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
      break;
    case QosProfile::kPose:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
      break;
    case QosProfile::kState:
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
  }
  return qos;
}

dds_entity_t create_topic(const Participant& p, const dds_topic_descriptor_t& d, const std::string& name) {
  return check(dds_create_topic(p.handle(), &d, name.c_str(), nullptr, nullptr), ("create topic " + name).c_str());
}

std::string config_uri() {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  return uri ? uri : "";
}

}  // namespace locd::dds
