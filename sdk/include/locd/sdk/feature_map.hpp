// A 2D geometric feature map: walls as polylines, expanded into the features a 2D laser sees:
// lines (each wall segment), corners (where two segments of a wall meet) and edges (free ends of
// a wall, e.g. door jambs). The same file is the simulator's world and feature_ekf's map.
//
//   frame_id: map
//   walls:                      # polylines, [x, y] in metres
//     - [[0, 0], [40, 0], [40, 3]]
//   closed: [true]              # optional per wall: last vertex joins the first (no edges)
//   lines:   [[x1, y1, x2, y2], ...]   # optional extra features given directly
//   corners: [[x, y], ...]
//   edges:   [[x, y], ...]
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "locd/sdk/params.hpp"

namespace locd {

struct LineFeature {
  std::string id;
  Eigen::Vector2d a, b;  // segment end points, map frame
  // Normal form: rho = x cos(alpha) + y sin(alpha), rho >= 0.
  double alpha() const;
  double rho() const;
};

struct PointFeature {
  std::string id;
  Eigen::Vector2d position;
};

struct FeatureMap2D {
  std::string frame_id = "map";
  std::vector<LineFeature> lines;
  std::vector<PointFeature> corners;
  std::vector<PointFeature> edges;
  size_t size() const { return lines.size() + corners.size() + edges.size(); }
};

// Parses a map from validated params (errors name the key and entry). max_features bounds the
// total before anything is stored.
FeatureMap2D parse_feature_map(const Params& params, size_t max_features);
FeatureMap2D load_feature_map(const std::string& file, size_t max_features);

}  // namespace locd
