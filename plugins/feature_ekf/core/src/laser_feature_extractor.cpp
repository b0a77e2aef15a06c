#include "locd/feature_ekf/laser_feature_extractor.hpp"

#include <algorithm>
#include <cmath>

#include "locd/sdk/gaussian.hpp"
#include "locd/sdk/geometry.hpp"

namespace locd::feature_ekf {

namespace {

// Gate of same_line: two pieces whose lines agree at this chi-square probability are one line.
constexpr double kSameLineProbability = 0.999;
// A gap between neighbouring points is a break when it exceeds the adaptive breakpoint distance
// plus this many range standard deviations (Borges and Aldon's noise allowance).
constexpr double kBreakpointNoiseSigmas = 3.0;
// A chord shorter than this (m) has no direction: split measures plain distances instead.
constexpr double kMinChordLength = 1e-9;
// Edges seen at |cos(incidence)| below this are grazing: the end is poorly defined along the line.
constexpr double kMinEdgeIncidence = 0.1;
// At most this many no-return or too-close readings amid a surface's returns are a dropout, not
// a gap: real lasers miss single beams on dark or shiny spots (a door is tens of beams wide).
constexpr size_t kDropoutBeams = 2;
// A fitted line's points along it need some spread (m^2) for its angle to have a variance.
constexpr double kMinLineSpread = 1e-12;

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
        length > kMinChordLength ? std::abs(chord.x() * d.y() - chord.y() * d.x()) / length : d.norm();
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
// chi-square gate of probability kSameLineProbability (2 dof) of their combined covariance.
bool same_line(const std::vector<Eigen::Vector2d>& points, const Segment& a, const Segment& b, double point_stddev) {
  static const double gate = chi_square_quantile(kSameLineProbability, 2);
  if (a.last - a.first < 2 || b.last - b.first < 2) return false;
  const LineFit fa = fit_line(points, a.first, a.last, point_stddev);
  const LineFit fb = fit_line(points, b.first, b.last, point_stddev);
  const Eigen::Vector2d difference(fa.z.x() - fb.z.x(), normalize_angle(fa.z.y() - fb.z.y()));
  const Eigen::Matrix2d S = fa.covariance + fb.covariance;
  return difference.dot(S.ldlt().solve(difference)) < gate;
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
  spread = std::max(spread, kMinLineSpread);
  const double variance = point_stddev * point_stddev;
  const double var_phi = variance / spread;
  const double ct = centroid.dot(direction);
  LineFit fit;
  fit.z = {r, phi};
  fit.covariance << variance / n + ct * ct * var_phi, ct * var_phi, ct * var_phi, var_phi;
  fit.max_residual = max_residual;
  return fit;
}

namespace {

// The scan's valid returns in beam order, as points in base_link with their beam and range.
struct ScanPoints {
  std::vector<Eigen::Vector2d> points;
  std::vector<size_t> beams;
  std::vector<double> ranges;
};

ScanPoints scan_points(const LaserScan& scan, const Pose2& sensor) {
  ScanPoints out;
  out.points.reserve(scan.ranges.size());
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    if (!scan.valid_return(i)) continue;
    const double r = scan.ranges[i], a = scan.angle(i);
    out.points.push_back(sensor.transform({r * std::cos(a), r * std::sin(a)}));
    out.beams.push_back(i);
    out.ranges.push_back(r);
  }
  return out;
}

// Line segments of the scan: clusters (runs of adjacent beams without a gap), each split and
// merged. cluster_start / cluster_end mark each cluster's first and last point.
struct Segmentation {
  std::vector<Segment> segments;
  std::vector<bool> cluster_start, cluster_end;
};

// Split and merge of one cluster [first, last] of the points.
std::vector<Segment> split_and_merge(const std::vector<Eigen::Vector2d>& points, size_t first, size_t last,
                                     const ExtractorConfig& c) {
  std::vector<Segment> pieces;
  split(points, first, last, c.split_distance, pieces);
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
  return merged;
}

// Whether the beams strictly between two returns break a surface: more than kDropoutBeams
// no-return or too-close readings do (something else, or nothing, was seen there); fewer are a
// dropout on the surface (a dark or shiny spot, dust). NaN and zero readings (REP 117: erroneous)
// say nothing, so a surface runs on across them.
bool broken_between(const LaserScan& scan, size_t first_beam, size_t second_beam) {
  size_t seen_elsewhere = 0;
  for (size_t b = first_beam + 1; b < second_beam; ++b) {
    if (scan.reading(b) != RangeReading::kInvalid) ++seen_elsewhere;
  }
  return seen_elsewhere > kDropoutBeams;
}

Segmentation segment(const LaserScan& scan, const ScanPoints& p, const ExtractorConfig& c) {
  Segmentation out;
  out.cluster_start.assign(p.points.size(), false);
  out.cluster_end.assign(p.points.size(), false);
  // Adaptive breakpoint (Borges and Aldon): beyond breakpoint_distance, a gap is still one surface
  // while that surface is seen at an incidence above breakpoint_min_incidence.
  const double beam_step = std::abs(static_cast<double>(scan.angle_increment));
  const auto adaptive_gain = [&](size_t beams_apart) {
    const double step = beam_step * static_cast<double>(beams_apart);
    return c.breakpoint_min_incidence > step ? std::sin(step) / std::sin(c.breakpoint_min_incidence - step) : 0.0;
  };
  size_t begin = 0;
  for (size_t i = 1; i <= p.points.size(); ++i) {
    const bool cut = i == p.points.size() || broken_between(scan, p.beams[i - 1], p.beams[i]) ||
                     (p.points[i] - p.points[i - 1]).norm() >
                         std::max(c.breakpoint_distance, adaptive_gain(p.beams[i] - p.beams[i - 1]) * p.ranges[i - 1] +
                                                             kBreakpointNoiseSigmas * c.range_stddev);
    if (!cut) continue;
    out.cluster_start[begin] = true;
    out.cluster_end[i - 1] = true;
    const std::vector<Segment> merged = split_and_merge(p.points, begin, i - 1, c);
    out.segments.insert(out.segments.end(), merged.begin(), merged.end());
    begin = i;
  }
  return out;
}

Eigen::Matrix2d diagonal_variance(double first_stddev, double second_stddev) {
  return Eigen::Vector2d(first_stddev * first_stddev, second_stddev * second_stddev).asDiagonal();
}

// Lines: segments with enough points and length, fitted by total least squares; kept holds the
// segment of each line.
void fit_lines(const ScanPoints& p, const std::vector<Segment>& segments, const ExtractorConfig& c,
               std::vector<ExtractedLine>& lines, std::vector<Segment>& kept) {
  const Eigen::Matrix2d line_floor = diagonal_variance(c.line_rho_stddev, c.line_alpha_stddev);
  for (const Segment& s : segments) {
    const int count = static_cast<int>(s.last - s.first + 1);
    if (count < c.min_points) continue;
    const LineFit fit = fit_line(p.points, s.first, s.last, c.range_stddev);
    const Eigen::Vector2d normal = normal_of(fit.z.y());
    ExtractedLine line;
    line.z = fit.z;
    line.start = p.points[s.first] - (p.points[s.first].dot(normal) - fit.z.x()) * normal;
    line.end = p.points[s.last] - (p.points[s.last].dot(normal) - fit.z.x()) * normal;
    if ((line.end - line.start).norm() < c.min_length) continue;
    line.covariance = fit.covariance + line_floor;
    line.first_beam = p.beams[s.first];
    line.last_beam = p.beams[s.last];
    line.points = count;
    lines.push_back(line);
    kept.push_back(s);
  }
}

// Corners: adjacent lines at >= corner_min_angle whose near ends lie close to their intersection.
std::vector<ExtractedPoint> find_corners(const std::vector<ExtractedLine>& lines, const ExtractorConfig& c) {
  const Eigen::Matrix2d line_floor = diagonal_variance(c.line_rho_stddev, c.line_alpha_stddev);
  const Eigen::Matrix2d point_floor = diagonal_variance(c.point_range_stddev, c.point_bearing_stddev);
  std::vector<ExtractedPoint> corners;
  for (size_t k = 0; k + 1 < lines.size(); ++k) {
    const ExtractedLine& l1 = lines[k];
    const ExtractedLine& l2 = lines[k + 1];
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
    corners.push_back(corner);
  }
  return corners;
}

// Edges: a line end at a cluster boundary whose neighbour beam hits a surface farther away and
// off the line's extension (the line occludes it). The true end lies between the two beams.
std::vector<ExtractedPoint> find_edges(const LaserScan& scan, const Pose2& sensor, const ScanPoints& p,
                                       const Segmentation& segmentation, const std::vector<ExtractedLine>& lines,
                                       const std::vector<Segment>& kept, const ExtractorConfig& c) {
  const Eigen::Matrix2d point_floor = diagonal_variance(c.point_range_stddev, c.point_bearing_stddev);
  const Eigen::Vector2d sensor_origin(sensor.x, sensor.y);
  const double beam_step = std::abs(static_cast<double>(scan.angle_increment));
  // The spread of a uniform error over one beam step: the end lies anywhere between two beams.
  const double uniform_stddev_per_step = beam_step / std::sqrt(12.0);
  // The neighbour beam saw something farther: a return beyond the jump, or open space (REP 117's
  // no return: +inf or a max-range reading). NaN, zero or too close says nothing.
  // A dropout (at most kDropoutBeams no-returns, then a return) is looked across.
  const auto neighbour_is_farther = [&](size_t beam, size_t end_index, int side) {
    size_t no_returns = 0;
    for (size_t b = beam; b < scan.ranges.size(); b = side < 0 ? b - 1 : b + 1) {  // below 0 wraps: ends
      const RangeReading reading = scan.reading(b);
      if (reading == RangeReading::kHit) {
        return scan.ranges[b] >= p.ranges[end_index] + c.edge_min_depth_jump;
      }
      if (reading == RangeReading::kTooClose) return false;
      if (reading == RangeReading::kNoReturn && ++no_returns > kDropoutBeams) return true;
      if (reading == RangeReading::kInvalid && no_returns == 0) return false;
    }
    return no_returns > 0;
  };
  std::vector<ExtractedPoint> edges;
  for (size_t k = 0; k < lines.size(); ++k) {
    const ExtractedLine& line = lines[k];
    const Eigen::Vector2d normal = normal_of(line.z.y()), direction = direction_of(line.z.y());
    for (int side : {-1, +1}) {
      const size_t end_index = side < 0 ? kept[k].first : kept[k].last;
      const bool at_boundary = side < 0 ? segmentation.cluster_start[end_index] : segmentation.cluster_end[end_index];
      if (!at_boundary) continue;
      if (side < 0 && p.beams[end_index] == 0) continue;  // the field of view ends here, not the surface
      if (side > 0 && p.beams[end_index] + 1 >= scan.ranges.size()) continue;
      const size_t neighbour = side < 0 ? end_index - 1 : end_index + 1;  // may be out of range (unused then)
      const size_t neighbour_beam = side < 0 ? p.beams[end_index] - 1 : p.beams[end_index] + 1;
      if (!neighbour_is_farther(neighbour_beam, end_index, side)) continue;
      const bool neighbour_hit = neighbour < p.points.size() && p.beams[neighbour] == neighbour_beam;
      if (neighbour_hit && std::abs(p.points[neighbour].dot(normal) - line.z.x()) < c.edge_min_depth_jump) continue;
      const double ray_angle = sensor.theta + scan.angle(p.beams[end_index]) + 0.5 * side * scan.angle_increment;
      const Eigen::Vector2d ray(std::cos(ray_angle), std::sin(ray_angle));
      const double incidence = std::abs(normal.dot(ray));
      if (incidence < kMinEdgeIncidence) continue;
      const double t = (line.z.x() - normal.dot(sensor_origin)) / normal.dot(ray);
      const Eigen::Vector2d position = sensor_origin + t * ray;
      const double sigma_along = uniform_stddev_per_step * std::abs(t) / incidence;
      const Eigen::Matrix2d position_covariance = direction * direction.transpose() * sigma_along * sigma_along +
                                                  normal * normal.transpose() * line.covariance(0, 0);
      Eigen::Matrix2d B;
      ExtractedPoint edge;
      edge.position = position;
      edge.z = range_bearing(position, &B);
      edge.covariance = B * position_covariance * B.transpose() + point_floor;
      edges.push_back(edge);
    }
  }
  return edges;
}

}  // namespace

ExtractedFeatures LaserFeatureExtractor::extract(const LaserScan& scan) const {
  ExtractedFeatures features;
  const Pose2 sensor = Pose2::from_isometry(scan.sensor_pose);
  const ScanPoints points = scan_points(scan, sensor);
  features.usable_returns = points.points.size();
  if (points.points.size() < 2) return features;
  const Segmentation segmentation = segment(scan, points, config_);
  std::vector<Segment> kept;
  fit_lines(points, segmentation.segments, config_, features.lines, kept);
  features.corners = find_corners(features.lines, config_);
  features.edges = find_edges(scan, sensor, points, segmentation, features.lines, kept, config_);
  return features;
}

}  // namespace locd::feature_ekf
