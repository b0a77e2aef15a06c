// A road network with non-unique road signs (Kim, Hong, Ra 2018, sec. 3): a grid of roads about
// an operating-area centre, signs of several classes placed at random along the roads beside the
// lane they face. Local coordinates are ENU metres about the centre; geodetic ones follow the
// flat mapping lat = lat0 + N / (R_m + h), lon = lon0 + E / ((R_t + h) cos lat0) (WGS84 radii at
// lat0). Deterministic from the seed.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "locd/sdk/params.hpp"

namespace locd::sim::road_signs {

struct WorldConfig {
  double centre_latitude_deg = 36.1;
  double centre_longitude_deg = 129.37;
  double altitude = 50.0;        // m
  int blocks_east = 4;           // grid of blocks_east x blocks_north blocks
  int blocks_north = 4;
  double block_size = 250.0;     // m between parallel roads
  double sign_offset = 6.0;      // m from the road's centre line, on the side of the lane it faces
  double min_sign_spacing = 8.0; // m along a road between two signs on the same side
  // Class name and how many signs of it (the paper's Table 2 counts).
  std::vector<std::pair<std::string, int>> classes = {
      {"school_zone", 8},  {"u_turn", 10},  {"speed_limit_60", 11}, {"unprotected_left", 15},
      {"no_parking", 23},  {"bus_stop", 25}, {"crosswalk", 40},      {"traffic_light", 93}};
  uint64_t seed = 3;

  static WorldConfig from_params(const Params& p);  // keys as above; classes: {name: count}
};

struct RoadSign {
  std::string id;
  std::string class_label;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // ENU m
  double facing = 0.0;      // ENU yaw of the traffic it faces (it is seen by vehicles heading so)
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
};

class RoadSignWorld {
 public:
  explicit RoadSignWorld(WorldConfig config);

  const WorldConfig& config() const { return config_; }
  const std::vector<RoadSign>& signs() const { return signs_; }
  // Intersections: node (i, j) at ((i - blocks_east / 2) * block, (j - blocks_north / 2) * block).
  Eigen::Vector2d node(int i, int j) const;
  double road_length() const;  // m, all roads
  // WGS84 radii at the centre (R_m, R_t) and the flat mapping.
  double meridian_radius() const { return meridian_radius_; }
  double transverse_radius() const { return transverse_radius_; }
  Eigen::Vector2d to_geodetic_deg(const Eigen::Vector2d& enu) const;  // (lat, lon)
  // The database file: header id,class,lat,lon, then one sign per line.
  std::string database_csv() const;

 private:
  WorldConfig config_;
  double meridian_radius_ = 0.0;
  double transverse_radius_ = 0.0;
  std::vector<RoadSign> signs_;
};

}  // namespace locd::sim::road_signs
