#include "locd/feature_ekf/landmark_database.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "locd/sdk/errors.hpp"

namespace locd::feature_ekf {

namespace {

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) fields.push_back(trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double parse_coordinate(const std::string& text, const std::string& where, const char* name) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) {
    throw ConfigError(where + ": " + name + " '" + text + "' is not a number");
  }
  return v;
}

void check_size(size_t count, size_t max_landmarks, const std::string& source) {
  if (count > max_landmarks) {
    throw ConfigError("landmark database " + source + ": more than " + std::to_string(max_landmarks) +
                      " landmarks (limit max_map_cells)");
  }
}

}  // namespace

LandmarkDatabase::LandmarkDatabase(std::vector<Landmark> landmarks, const std::string& source)
    : landmarks_(std::move(landmarks)) {
  if (landmarks_.empty()) throw ConfigError("landmark database " + source + ": no landmarks");
  for (size_t i = 0; i < landmarks_.size(); ++i) {
    const Landmark& l = landmarks_[i];
    const std::string where = "landmark database " + source + ", entry " + std::to_string(i + 1);
    if (l.id.empty()) throw ConfigError(where + ": empty id");
    if (l.class_label.empty()) throw ConfigError(where + " (id '" + l.id + "'): empty class");
    if (l.id.find('#') != std::string::npos || l.class_label.find('#') != std::string::npos) {
      throw ConfigError(where + " (id '" + l.id + "'): '#' is reserved (detection labels 'class#id')");
    }
    if (!std::isfinite(l.latitude_deg) || std::fabs(l.latitude_deg) > 90.0) {
      throw ConfigError(where + " (id '" + l.id + "'): lat " + std::to_string(l.latitude_deg) +
                        " is out of range; allowed: [-90, 90] degrees");
    }
    if (!std::isfinite(l.longitude_deg) || std::fabs(l.longitude_deg) > 180.0) {
      throw ConfigError(where + " (id '" + l.id + "'): lon " + std::to_string(l.longitude_deg) +
                        " is out of range; allowed: [-180, 180] degrees");
    }
    if (!by_id_.emplace(l.id, static_cast<int>(i)).second) {
      throw ConfigError(where + ": duplicate id '" + l.id + "' (first at entry " +
                        std::to_string(by_id_[l.id] + 1) + ")");
    }
    by_class_[l.class_label].push_back(static_cast<int>(i));
  }
}

const std::vector<int>& LandmarkDatabase::of_class(const std::string& class_label) const {
  static const std::vector<int> kNone;
  const auto it = by_class_.find(class_label);
  return it == by_class_.end() ? kNone : it->second;
}

int LandmarkDatabase::index_of(const std::string& id) const {
  const auto it = by_id_.find(id);
  return it == by_id_.end() ? -1 : it->second;
}

std::vector<std::string> LandmarkDatabase::classes() const {
  std::vector<std::string> names;
  for (const auto& [name, indices] : by_class_) names.push_back(name);
  return names;
}

void LandmarkDatabase::centre_deg(double* latitude_deg, double* longitude_deg) const {
  double lat_min = 90, lat_max = -90, lon_min = 180, lon_max = -180;
  for (const Landmark& l : landmarks_) {
    lat_min = std::min(lat_min, l.latitude_deg);
    lat_max = std::max(lat_max, l.latitude_deg);
    lon_min = std::min(lon_min, l.longitude_deg);
    lon_max = std::max(lon_max, l.longitude_deg);
  }
  *latitude_deg = 0.5 * (lat_min + lat_max);
  *longitude_deg = 0.5 * (lon_min + lon_max);
}

LandmarkDatabase parse_landmark_csv(const std::string& text, const std::string& source, size_t max_landmarks) {
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  bool header_seen = false;
  std::vector<Landmark> landmarks;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> f = split_csv_line(t);
    const std::string where = "landmark database " + source + ", line " + std::to_string(line_number);
    if (!header_seen) {
      if (f != std::vector<std::string>{"id", "class", "lat", "lon"}) {
        throw ConfigError(where + ": header '" + t + "' must be 'id,class,lat,lon'");
      }
      header_seen = true;
      continue;
    }
    if (f.size() != 4) {
      throw ConfigError(where + ": " + std::to_string(f.size()) + " fields; expected 4 (id,class,lat,lon)");
    }
    check_size(landmarks.size() + 1, max_landmarks, source);
    landmarks.push_back({f[0], f[1], parse_coordinate(f[2], where, "lat"), parse_coordinate(f[3], where, "lon")});
  }
  if (!header_seen) throw ConfigError("landmark database " + source + ": empty (expected header 'id,class,lat,lon')");
  return LandmarkDatabase(std::move(landmarks), source);
}

LandmarkDatabase parse_landmark_yaml(const std::string& text, const std::string& source, size_t max_landmarks) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError("landmark database " + source + ": " + e.what());
  }
  const YAML::Node list = root["landmarks"];
  if (!list || !list.IsSequence()) {
    throw ConfigError("landmark database " + source + ": expected a list 'landmarks: [{id, class, lat, lon}, ...]'");
  }
  check_size(list.size(), max_landmarks, source);
  std::vector<Landmark> landmarks;
  for (const YAML::Node& entry : list) {
    const std::string where = "landmark database " + source + ", line " + std::to_string(entry.Mark().line + 1);
    if (!entry.IsMap()) throw ConfigError(where + ": an entry must be a map {id, class, lat, lon}");
    for (const auto& kv : entry) {
      const std::string key = kv.first.as<std::string>();
      if (key != "id" && key != "class" && key != "lat" && key != "lon") {
        throw ConfigError(where + ": unknown key '" + key + "'; allowed: id, class, lat, lon");
      }
    }
    for (const char* key : {"id", "class", "lat", "lon"}) {
      if (!entry[key] || !entry[key].IsScalar()) throw ConfigError(where + ": missing '" + key + "'");
    }
    landmarks.push_back({entry["id"].as<std::string>(), entry["class"].as<std::string>(),
                         parse_coordinate(entry["lat"].as<std::string>(), where, "lat"),
                         parse_coordinate(entry["lon"].as<std::string>(), where, "lon")});
  }
  return LandmarkDatabase(std::move(landmarks), source);
}

LandmarkDatabase load_landmark_database(const std::string& file, size_t max_landmarks) {
  std::ifstream in(file);
  if (!in) throw ConfigError("landmark database " + file + ": cannot be read");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const bool csv = file.size() >= 4 && file.compare(file.size() - 4, 4, ".csv") == 0;
  return csv ? parse_landmark_csv(text, file, max_landmarks) : parse_landmark_yaml(text, file, max_landmarks);
}

}  // namespace locd::feature_ekf
