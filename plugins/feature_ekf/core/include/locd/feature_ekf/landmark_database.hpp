// The landmark database of assumption A4: every landmark's id, class and absolute position
// (WGS84 degrees). Many landmarks share a class (non-unique features, eq. 15).
// Files: YAML (`landmarks: [{id, class, lat, lon}, ...]`) or CSV (header `id,class,lat,lon`).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace locd::feature_ekf {

struct Landmark {
  std::string id;
  std::string class_label;
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
};

class LandmarkDatabase {
 public:
  LandmarkDatabase() = default;
  // Throws locd::ConfigError naming `source` (and the line) on duplicate ids, coordinates out of
  // range, empty ids or classes.
  LandmarkDatabase(std::vector<Landmark> landmarks, const std::string& source);

  const std::vector<Landmark>& landmarks() const { return landmarks_; }
  size_t size() const { return landmarks_.size(); }
  const Landmark& operator[](size_t i) const { return landmarks_[i]; }
  // Indices of a class's landmarks (empty when the class is unknown): the hypotheses of eq. 15.
  const std::vector<int>& of_class(const std::string& class_label) const;
  bool has_class(const std::string& class_label) const { return by_class_.count(class_label) > 0; }
  int index_of(const std::string& id) const;  // -1 when absent
  std::vector<std::string> classes() const;
  // Centre of the landmarks' bounding box (degrees): the default operating area centre (A5).
  void centre_deg(double* latitude_deg, double* longitude_deg) const;

 private:
  std::vector<Landmark> landmarks_;
  std::map<std::string, std::vector<int>> by_class_;
  std::map<std::string, int> by_id_;
};

// By extension: .csv is CSV, anything else YAML. At most max_landmarks entries are read.
LandmarkDatabase load_landmark_database(const std::string& file, size_t max_landmarks);
LandmarkDatabase parse_landmark_csv(const std::string& text, const std::string& source, size_t max_landmarks);
LandmarkDatabase parse_landmark_yaml(const std::string& text, const std::string& source, size_t max_landmarks);

}  // namespace locd::feature_ekf
