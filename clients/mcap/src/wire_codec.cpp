#include "locd/mcap/wire_codec.hpp"

#include <dds/ddsi/ddsi_cdrstream.h>

#include <cstring>
#include <stdexcept>

namespace locd::mcap {

extern const char* const kLocdIdlText;  // locd_idl_text.cpp, generated from idl/locd.idl

namespace {
constexpr uint32_t kXcdr1 = 1, kXcdr2 = 2;
}

const std::vector<TopicInfo>& locd_topics() {
  using namespace locd::topics;
  // clang-format off
  static const std::vector<TopicInfo> topics = {
      {kOdometry, "locd::msg::Odometry", &locd_msg_Odometry_desc, true, false, true},
      {kImu, "locd::msg::Imu", &locd_msg_Imu_desc, true, false, true},
      {kScan, "locd::msg::LaserScan", &locd_msg_LaserScan_desc, true, false, true},
      {kCloud, "locd::msg::PointCloud", &locd_msg_PointCloud_desc, true, false, true},
      {kImage, "locd::msg::Image", &locd_msg_Image_desc, true, false, true},
      {kDetections, "locd::msg::LandmarkDetections", &locd_msg_LandmarkDetections_desc, true, false, true},
      {kInitialPose, "locd::msg::InitialPose", &locd_msg_InitialPose_desc, true, true, true},
      {kSessionRequest, "locd::msg::SessionRequest", &locd_msg_SessionRequest_desc, true, true, true},
      {kMapSaveRequest, "locd::msg::MapSaveRequest", &locd_msg_MapSaveRequest_desc, true, false, true},
      {kPose, "locd::msg::PoseEstimate", &locd_msg_PoseEstimate_desc, true, false, false, true},
      {kDiagnostics, "locd::msg::Diagnostics", &locd_msg_Diagnostics_desc, true, false, false, true},
      {kGrid, "locd::msg::GridMap", &locd_msg_GridMap_desc, true, true, false, true},
      {kMapCloud, "locd::msg::PointCloudMap", &locd_msg_PointCloudMap_desc, true, true, false, true},
      {kLandmarkMap, "locd::msg::LandmarkMap", &locd_msg_LandmarkMap_desc, true, true, false, true},
      {kExplorationGoal, "locd::msg::ExplorationGoal", &locd_msg_ExplorationGoal_desc, true, true, false, true},
      {kSessionStatus, "locd::msg::SessionStatus", &locd_msg_SessionStatus_desc, true, true, false},
      {kGroundTruth, "locd::msg::PoseEstimate", &locd_msg_PoseEstimate_desc, true, false, false},
      {kServerInfo, "locd::msg::ServerInfo", &locd_msg_ServerInfo_desc, false, true, false},
  };
  // clang-format on
  return topics;
}

const TopicInfo* find_topic(const std::string& dds_topic) {
  for (const TopicInfo& t : locd_topics()) {
    if (dds_topic == t.topic) return &t;
  }
  return nullptr;
}

const std::string& locd_idl() {
  static const std::string text = kLocdIdlText;
  return text;
}

std::string channel_topic(const TopicInfo& topic, const std::string& robot_id) {
  return topic.per_robot ? robot_id + "/" + topic.topic : std::string(topic.topic);
}

std::vector<uint8_t> encode(const dds_topic_descriptor_t& descriptor, const void* sample) {
  dds_ostream_t os;
  dds_ostream_init(&os, 0, kXcdr1);
  dds_stream_write(&os, static_cast<const char*>(sample), descriptor.m_ops);
  std::vector<uint8_t> out(4 + os.m_index);
  out[0] = 0x00;
  out[1] = 0x01;  // CDR_LE (this machine writes little endian)
  std::memcpy(out.data() + 4, os.m_buffer, os.m_index);
  dds_ostream_fini(&os);
  return out;
}

void SampleDeleter::operator()(void* sample) const { dds_sample_free(sample, descriptor, DDS_FREE_ALL); }

SamplePtr decode(const dds_topic_descriptor_t& descriptor, const uint8_t* data, size_t size) {
  const std::string type = descriptor.m_typename;
  if (size < 4) throw std::invalid_argument(type + ": " + std::to_string(size) + " bytes, shorter than the CDR header");
  if (size > 0xffffffffu) throw std::invalid_argument(type + ": larger than 4 GiB");
  const uint16_t id = static_cast<uint16_t>(data[0] << 8 | data[1]);
  uint32_t version = 0;
  bool big_endian = false;
  switch (id) {
    case 0x0000: version = kXcdr1; big_endian = true; break;   // CDR_BE
    case 0x0001: version = kXcdr1; break;                       // CDR_LE
    case 0x0006: version = kXcdr2; big_endian = true; break;   // CDR2_BE (plain, @final)
    case 0x0007: version = kXcdr2; break;                       // CDR2_LE
    default:
      throw std::invalid_argument(type + ": encapsulation 0x" + std::to_string(id) +
                                  " is not CDR or plain CDR2 (0x0000, 0x0001, 0x0006, 0x0007)");
  }
  const bool swap = big_endian != (DDSRT_ENDIAN == DDSRT_BIG_ENDIAN);
  // The normalizer works in place (byte swap) and wants aligned data: copy the payload.
  const uint32_t payload = static_cast<uint32_t>(size - 4);
  std::vector<uint64_t> aligned((payload + 7) / 8 + 1);
  std::memcpy(aligned.data(), data + 4, payload);
  char* buffer = reinterpret_cast<char*>(aligned.data());
  uint32_t used = 0;
  if (!dds_stream_normalize_data(buffer, &used, payload, swap, version, descriptor.m_ops)) {
    throw std::invalid_argument(type + ": the " + std::to_string(payload) +
                                " bytes are not a valid sample (a length beyond its bound or beyond the data)");
  }
  SamplePtr sample(dds_alloc(descriptor.m_size), SampleDeleter{&descriptor});
  std::memset(sample.get(), 0, descriptor.m_size);
  dds_istream_t is;
  dds_istream_init(&is, payload, buffer, version);
  dds_stream_read(&is, static_cast<char*>(sample.get()), descriptor.m_ops);
  return sample;
}

std::string robot_id_of(const uint8_t* data, size_t size) {
  if (size < 8) return "";
  const bool big_endian = data[1] == 0x00 || data[1] == 0x06;
  const uint8_t* p = data + 4;
  const uint32_t length = big_endian ? (uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3])
                                     : (uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0]);
  if (length < 1 || length > 65 || 8 + static_cast<size_t>(length) > size) return "";
  if (p[4 + length - 1] != '\0') return "";
  return std::string(reinterpret_cast<const char*>(p + 4), length - 1);
}

}  // namespace locd::mcap
