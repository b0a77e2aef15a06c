#include "locd/server/resume.hpp"

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "locd/sdk/robot_id.hpp"
#include "locd/sdk/validate.hpp"

namespace locd::server {
namespace {

using Json = nlohmann::json;
constexpr int kStateFileVersion = 1;

Json pose_json(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  return Json::array({t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()});
}

Eigen::Isometry3d pose_from_json(const Json& j) {
  if (!j.is_array() || j.size() != 7) throw std::runtime_error("a pose is [x, y, z, qx, qy, qz, qw]");
  Eigen::Quaterniond q(j[6].get<double>(), j[3].get<double>(), j[4].get<double>(), j[5].get<double>());
  if (!(q.norm() > 0.5 && q.norm() < 2.0)) throw std::runtime_error("a pose's quaternion is not a rotation");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  return T;
}

}  // namespace

std::optional<Eigen::Isometry3d> odometry_at(const Odometry& latest, int64_t stamp_ns) {
  const int64_t gap = stamp_ns - latest.header.stamp_ns;
  if (gap < -kMaxOdometryExtrapolationNs || gap > kMaxOdometryExtrapolationNs) return std::nullopt;
  const double dt = static_cast<double>(gap) * 1e-9;
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d rotation = latest.angular_velocity * dt;
  if (rotation.norm() > 0.0) motion.linear() = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix();
  motion.translation() = latest.linear_velocity * dt;
  return latest.pose * motion;
}

std::optional<Eigen::Isometry3d> map_from_odom(const PoseEstimate& estimate, const Odometry& latest) {
  const auto odom = odometry_at(latest, estimate.header.stamp_ns);
  if (!odom) return std::nullopt;
  return estimate.pose * odom->inverse();
}

PoseEstimate resume_pose(const ResumeState& state, const Odometry* next_odometry) {
  PoseEstimate pose = state.estimate;
  if (state.map_from_odom && next_odometry && next_odometry->header.stamp_ns >= state.estimate.header.stamp_ns) {
    pose.pose = *state.map_from_odom * next_odometry->pose;
    pose.header.stamp_ns = next_odometry->header.stamp_ns;
  }
  return pose;
}

StateFile::StateFile(std::filesystem::path directory)
    : directory_(std::move(directory)), file_(directory_.empty() ? directory_ : directory_ / "sessions.json") {}

std::map<std::string, ResumeState> StateFile::load(Logger& logger) const {
  std::map<std::string, ResumeState> states;
  if (!enabled()) return states;
  std::error_code ec;
  if (!std::filesystem::exists(file_, ec)) return states;
  const auto size = std::filesystem::file_size(file_, ec);
  if (ec || size > kMaxStateFileBytes) {
    logger.log(LogLevel::kError, "server",
               "state file " + file_.string() + " ignored: " +
                   (ec ? ec.message() : std::to_string(size) + " bytes exceed " + std::to_string(kMaxStateFileBytes)));
    return states;
  }
  std::ifstream in(file_);
  std::stringstream text;
  text << in.rdbuf();
  Json root;
  try {
    root = Json::parse(text.str());
    if (root.value("version", 0) != kStateFileVersion || !root.contains("robots") || !root["robots"].is_object()) {
      throw std::runtime_error("expected {\"version\": " + std::to_string(kStateFileVersion) + ", \"robots\": {...}}");
    }
  } catch (const std::exception& e) {
    logger.log(LogLevel::kError, "server", "state file " + file_.string() + " ignored: " + e.what());
    return states;
  }
  for (const auto& [robot_id, entry] : root["robots"].items()) {
    try {
      if (const std::string error = robot_id_error(robot_id); !error.empty()) throw std::runtime_error(error);
      ResumeState s;
      s.plugin = entry.at("plugin").get<std::string>();
      s.request_id = entry.at("request_id").get<uint64_t>();
      s.failed = entry.value("failed", false);
      s.estimate.header.stamp_ns = entry.at("stamp_ns").get<int64_t>();
      s.estimate.header.frame_id = "map";
      s.estimate.pose = pose_from_json(entry.at("pose"));
      const auto& covariance = entry.at("covariance");
      if (!covariance.is_array() || covariance.size() != 36) throw std::runtime_error("covariance needs 36 numbers");
      for (int i = 0; i < 36; ++i) s.estimate.covariance(i / 6, i % 6) = covariance[i].get<double>();
      if (entry.contains("map_from_odom")) s.map_from_odom = pose_from_json(entry["map_from_odom"]);
      s.claim_strength = entry.value("claim_strength", 0);
      validate(s.estimate);
      states[robot_id] = std::move(s);
    } catch (const std::exception& e) {
      logger.log(LogLevel::kWarning, "server",
                 "state file " + file_.string() + ": entry for robot '" + robot_id + "' skipped: " + e.what());
    }
  }
  return states;
}

std::string StateFile::encode(const std::map<std::string, ResumeState>& states) {
  Json robots = Json::object();
  for (const auto& [robot_id, s] : states) {
    Json entry = {{"plugin", s.plugin},
                  {"request_id", s.request_id},
                  {"failed", s.failed},
                  {"stamp_ns", s.estimate.header.stamp_ns},
                  {"pose", pose_json(s.estimate.pose)}};
    Json covariance = Json::array();
    for (int i = 0; i < 36; ++i) covariance.push_back(s.estimate.covariance(i / 6, i % 6));
    entry["covariance"] = std::move(covariance);
    if (s.map_from_odom) entry["map_from_odom"] = pose_json(*s.map_from_odom);
    if (s.claim_strength != 0) entry["claim_strength"] = s.claim_strength;
    robots[robot_id] = std::move(entry);
  }
  const Json root = {{"version", kStateFileVersion}, {"robots", std::move(robots)}};
  return root.dump() + "\n";
}

void StateFile::write(const std::string& text) const {
  if (!enabled()) return;
  const std::filesystem::path temporary = file_.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + temporary.string());
  }
  std::error_code ec;
  std::filesystem::rename(temporary, file_, ec);
  if (ec) throw std::runtime_error("cannot rename " + temporary.string() + " to " + file_.string() + ": " + ec.message());
}

}  // namespace locd::server
