#include "locd/feature_ekf/laser_feature_extractor.hpp"

#include <algorithm>
#include <cmath>

#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

namespace {

struct Segment {
  size_t first = 0, last = 0;  // indices into the point list, inclusive
};

Eigen::Vector2d normal_of(double phi) { return {std::cos(phi), std::sin(phi)}; }
Eigen::Vector2d direction_of(double phi) { return {-std::sin(phi), std::cos(phi)}; }

// Range-bearing of a robot-frame point and its Jacobian d(range, bearing)/d(x, y).
Eigen::Vector2d range_bearing(const Eigen::Vector2d& p, Eigen::Matrix2d* B) {
  const double d2 = p.squaredNorm(), d = std::sqrt(d2);
  *B << p.x() / d, p.y() / d, -p.y() / d2, p.x() / d2;
  return {d, std::atan2(p.y(), p.x())};
}

void split(const std::vector<Eigen::Vector2d>& points, size_t first, size_t last, double split_distance,
           std::vector<Segment>& out) {
  if (last - first < 2) {
    out.push_back({first, last});
    return;
  }
  const Eigen::Vector2d a = points[first];
  Eigen::Vector2d chord = points[last] - a;
  const double length = chord.norm();
  double worst = 0.0;
  size_t worst_index = first;
  for (size_t i = first + 1; i < last; ++i) {
    const Eigen::Vector2d d = points[i] - a;
    const double distance =
        length > 1e-9 ? std::abs(chord.x() * d.y() - chord.y() * d.x()) / length : d.norm();
    if (distance > worst) {
      worst = distance;
      worst_index = i;
    }
  }
  if (worst <= split_distance) {
    out.push_back({first, last});
    return;
  }
  split(points, first, worst_index, split_distance, out);
  split(points, worst_index, last, split_distance, out);
}

// Two pieces cut apart by a noisy point still fit one line: their (r, phi) agree within the
// chi-square 99.9 % gate of their combined covariance.
bool same_line(const std::vector<Eigen::Vector2d>& points, const Segment& a, const Segment& b, double point_stddev) {
  if (a.last - a.first < 2 || b.last - b.first < 2) return false;
  const LineFit fa = fit_line(points, a.first, a.last, point_stddev);
  const LineFit fb = fit_line(points, b.first, b.last, point_stddev);
  const Eigen::Vector2d difference(fa.z.x() - fb.z.x(), normalize_angle(fa.z.y() - fb.z.y()));
  const Eigen::Matrix2d S = fa.covariance + fb.covariance;
  return difference.dot(S.ldlt().solve(difference)) < 13.82;
}

}  // namespace

LineFit fit_line(const std::vector<Eigen::Vector2d>& points, size_t first, size_t last, double point_stddev) {
  const double n = static_cast<double>(last - first + 1);
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (size_t i = first; i <= last; ++i) centroid += points[i];
  centroid /= n;
  double sxx = 0, syy = 0, sxy = 0;
  for (size_t i = first; i <= last; ++i) {
    const Eigen::Vector2d d = points[i] - centroid;
    sxx += d.x() * d.x();
    syy += d.y() * d.y();
    sxy += d.x() * d.y();
  }
  double phi = 0.5 * std::atan2(-2.0 * sxy, syy - sxx);
  double r = centroid.dot(normal_of(phi));
  if (r < 0.0) {
    r = -r;
    phi += M_PI;
  }
  phi = normalize_angle(phi);
  const Eigen::Vector2d normal = normal_of(phi), direction = direction_of(phi);
  double spread = 0.0, max_residual = 0.0;
  for (size_t i = first; i <= last; ++i) {
    const double s = (points[i] - centroid).dot(direction);
    spread += s * s;
    max_residual = std::max(max_residual, std::abs(points[i].dot(normal) - r));
  }
  spread = std::max(spread, 1e-12);
  const double variance = point_stddev * point_stddev;
  const double var_phi = variance / spread;
  const double ct = centroid.dot(direction);
  LineFit fit;
  fit.z = {r, phi};
  fit.covariance << variance / n + ct * ct * var_phi, ct * var_phi, ct * var_phi, var_phi;
  fit.max_residual = max_residual;
  return fit;
}

ExtractedFeatures LaserFeatureExtractor::extract(const LaserScan& scan) const {
  const ExtractorConfig& c = config_;
  ExtractedFeatures features;
  const Pose2 sensor = Pose2::from_isometry(scan.sensor_pose);
  const Eigen::Vector2d sensor_origin(sensor.x, sensor.y);

  std::vector<Eigen::Vector2d> points;
  std::vector<size_t> beams;
  std::vector<double> ranges;
  points.reserve(scan.ranges.size());
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    if (!scan.valid_return(i)) continue;
    const double r = scan.ranges[i], a = scan.angle(i);
    points.push_back(sensor.transform({r * std::cos(a), r * std::sin(a)}));
    beams.push_back(i);
    ranges.push_back(r);
  }
  features.usable_returns = points.size();
  if (points.size() < 2) return features;

  // Clusters: runs of adjacent beams without a gap; each split and merged into segments.
  std::vector<bool> cluster_start(points.size(), false), cluster_end(points.size(), false);
  std::vector<Segment> segments;
  // Adaptive breakpoint (Borges and Aldon): beyond breakpoint_distance, a gap is still one surface
  // while that surface is seen at an incidence above breakpoint_min_incidence.
  const double step = std::abs(static_cast<double>(scan.angle_increment));
  const double adaptive_gain = c.breakpoint_min_incidence > step
                                   ? std::sin(step) / std::sin(c.breakpoint_min_incidence - step)
                                   : 0.0;
  size_t begin = 0;
  for (size_t i = 1; i <= points.size(); ++i) {
    const bool cut = i == points.size() || beams[i] != beams[i - 1] + 1 ||
                     (points[i] - points[i - 1]).norm() >
                         std::max(c.breakpoint_distance, adaptive_gain * ranges[i - 1] + 3.0 * c.range_stddev);
    if (!cut) continue;
    cluster_start[begin] = true;
    cluster_end[i - 1] = true;
    std::vector<Segment> pieces;
    split(points, begin, i - 1, c.split_distance, pieces);
    std::vector<Segment> merged;
    Segment current = pieces.front();
    for (size_t k = 1; k < pieces.size(); ++k) {
      if (fit_line(points, current.first, pieces[k].last, c.range_stddev).max_residual <= c.split_distance ||
          same_line(points, current, pieces[k], c.range_stddev)) {
        current.last = pieces[k].last;
      } else if (pieces[k].last - pieces[k].first < 2 && k + 1 < pieces.size() &&
                 same_line(points, current, pieces[k + 1], c.range_stddev)) {
        current.last = pieces[++k].last;  // a stray point between two pieces of one line
      } else {
        merged.push_back(current);
        current = pieces[k];
      }
    }
    merged.push_back(current);
    // A split point lies on one of its two segments only (or near the corner between them):
    // fitting neither with it keeps both fits unbiased.
    for (size_t k = 1; k < merged.size(); ++k) {
      if (merged[k].first == merged[k - 1].last && merged[k].first < merged[k].last &&
          merged[k - 1].first < merged[k - 1].last) {
        ++merged[k].first;
        --merged[k - 1].last;
      }
    }
    segments.insert(segments.end(), merged.begin(), merged.end());
    begin = i;
  }

  const Eigen::Matrix2d line_floor =
      Eigen::Vector2d(c.line_rho_stddev * c.line_rho_stddev, c.line_alpha_stddev * c.line_alpha_stddev).asDiagonal();
  const Eigen::Matrix2d point_floor =
      Eigen::Vector2d(c.point_range_stddev * c.point_range_stddev, c.point_bearing_stddev * c.point_bearing_stddev)
          .asDiagonal();

  std::vector<Segment> kept;
  for (const Segment& s : segments) {
    const int count = static_cast<int>(s.last - s.first + 1);
    if (count < c.min_points) continue;
    const LineFit fit = fit_line(points, s.first, s.last, c.range_stddev);
    const Eigen::Vector2d normal = normal_of(fit.z.y());
    ExtractedLine line;
    line.z = fit.z;
    line.start = points[s.first] - (points[s.first].dot(normal) - fit.z.x()) * normal;
    line.end = points[s.last] - (points[s.last].dot(normal) - fit.z.x()) * normal;
    if ((line.end - line.start).norm() < c.min_length) continue;
    line.covariance = fit.covariance + line_floor;
    line.first_beam = beams[s.first];
    line.last_beam = beams[s.last];
    line.points = count;
    features.lines.push_back(line);
    kept.push_back(s);
  }

  // Corners: adjacent lines at >= corner_min_angle whose near ends lie close to their intersection.
  for (size_t k = 0; k + 1 < features.lines.size(); ++k) {
    const ExtractedLine& l1 = features.lines[k];
    const ExtractedLine& l2 = features.lines[k + 1];
    const Eigen::Vector2d n1 = normal_of(l1.z.y()), n2 = normal_of(l2.z.y());
    const double angle_between = std::acos(std::min(1.0, std::abs(direction_of(l1.z.y()).dot(direction_of(l2.z.y())))));
    if (angle_between < c.corner_min_angle) continue;
    Eigen::Matrix2d A;
    A << n1.transpose(), n2.transpose();
    const Eigen::Matrix2d A_inverse = A.inverse();
    const Eigen::Vector2d p = A_inverse * Eigen::Vector2d(l1.z.x(), l2.z.x());
    if ((p - l1.end).norm() > c.corner_max_gap || (p - l2.start).norm() > c.corner_max_gap) continue;
    // p = A^-1 (r1, r2); d p / d(r1, phi1, r2, phi2) from n_i . p = r_i.
    Eigen::Matrix<double, 2, 4> J_lines = Eigen::Matrix<double, 2, 4>::Zero();
    J_lines(0, 0) = 1.0;
    J_lines(0, 1) = -direction_of(l1.z.y()).dot(p);
    J_lines(1, 2) = 1.0;
    J_lines(1, 3) = -direction_of(l2.z.y()).dot(p);
    Eigen::Matrix4d line_covariance = Eigen::Matrix4d::Zero();
    line_covariance.topLeftCorner<2, 2>() = l1.covariance - line_floor;
    line_covariance.bottomRightCorner<2, 2>() = l2.covariance - line_floor;
    const Eigen::Matrix<double, 2, 4> J_point = A_inverse * J_lines;
    Eigen::Matrix2d B;
    ExtractedPoint corner;
    corner.position = p;
    corner.z = range_bearing(p, &B);
    corner.covariance = B * J_point * line_covariance * J_point.transpose() * B.transpose() + point_floor;
    features.corners.push_back(corner);
  }

  // Edges: a line end at a cluster boundary whose neighbour beam hits a surface farther away and
  // off the line's extension (the line occludes it). The true end lies between the two beams.
  const double beam_step = std::abs(static_cast<double>(scan.angle_increment));
  // The neighbour beam saw something farther: a return beyond the jump, or open space (a range
  // above range_max or +inf). NaN or a range below range_min says nothing.
  const auto neighbour_is_farther = [&](size_t beam, size_t end_index) {
    const float r = scan.ranges[beam];
    if (scan.valid_return(beam)) return r >= ranges[end_index] + c.edge_min_depth_jump;
    return r > scan.range_max;
  };
  for (size_t k = 0; k < features.lines.size(); ++k) {
    const ExtractedLine& line = features.lines[k];
    const Eigen::Vector2d normal = normal_of(line.z.y()), direction = direction_of(line.z.y());
    for (int side : {-1, +1}) {
      const size_t end_index = side < 0 ? kept[k].first : kept[k].last;
      const bool at_boundary = side < 0 ? cluster_start[end_index] : cluster_end[end_index];
      if (!at_boundary) continue;
      if (side < 0 && beams[end_index] == 0) continue;  // the field of view ends here, not the surface
      if (side > 0 && beams[end_index] + 1 >= scan.ranges.size()) continue;
      const size_t neighbour = side < 0 ? end_index - 1 : end_index + 1;  // may be out of range (unused then)
      const size_t neighbour_beam = side < 0 ? beams[end_index] - 1 : beams[end_index] + 1;
      if (!neighbour_is_farther(neighbour_beam, end_index)) continue;
      const bool neighbour_hit = neighbour < points.size() && beams[neighbour] == neighbour_beam;
      if (neighbour_hit && std::abs(points[neighbour].dot(normal) - line.z.x()) < c.edge_min_depth_jump) continue;
      const double ray_angle = sensor.theta + scan.angle(beams[end_index]) + 0.5 * side * scan.angle_increment;
      const Eigen::Vector2d ray(std::cos(ray_angle), std::sin(ray_angle));
      const double incidence = std::abs(normal.dot(ray));
      if (incidence < 0.1) continue;  // grazing: the end is poorly defined along the line
      const double t = (line.z.x() - normal.dot(sensor_origin)) / normal.dot(ray);
      const Eigen::Vector2d p = sensor_origin + t * ray;
      const double sigma_along = beam_step / std::sqrt(12.0) * std::abs(t) / incidence;
      const Eigen::Matrix2d position_covariance = direction * direction.transpose() * sigma_along * sigma_along +
                                                  normal * normal.transpose() * line.covariance(0, 0);
      Eigen::Matrix2d B;
      ExtractedPoint edge;
      edge.position = p;
      edge.z = range_bearing(p, &B);
      edge.covariance = B * position_covariance * B.transpose() + point_floor;
      features.edges.push_back(edge);
    }
  }
  return features;
}

}  // namespace locd::feature_ekf
