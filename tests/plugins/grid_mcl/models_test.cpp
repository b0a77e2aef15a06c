// grid_mcl's models against their formulas: the beams AMCL picks, the likelihood field's table
// path against the direct formula (exp per beam) and by hand, the beam model's mixture by hand,
// and the motion models' sampled spread against their stated standard deviations.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "locd/grid_mcl/grid_particle_filter.hpp"
#include "locd/grid_mcl/laser_models.hpp"
#include "locd/grid_mcl/motion_models.hpp"
#include "locd/sdk/geometry.hpp"

namespace {

using namespace locd;
using namespace locd::grid_mcl;

// A 10 x 6 m room at 0.05 m, cell centres on multiples of 0.05 m: walls one cell thick centred on
// x = 0, 10 and y = 0, 6, free inside, a pillar at (6, 3).
std::shared_ptr<const SharedMap> room() {
  static const std::shared_ptr<const SharedMap> map = [] {
    GridGeometry g;
    g.resolution = 0.05;
    g.origin = Eigen::Vector2d(-0.525, -0.525);
    g.width = 222;
    g.height = 142;
    std::vector<int8_t> cells(g.size(), OccupancyMap::kUnknown);
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) {
        const Eigen::Vector2d p = g.center_of(r, c);
        const bool inside = p.x() > 0 && p.x() < 10 && p.y() > 0 && p.y() < 6;
        const bool wall = (std::abs(p.x()) < 0.01 || std::abs(p.x() - 10) < 0.01) && p.y() > -0.01 && p.y() < 6.01;
        const bool wall2 = (std::abs(p.y()) < 0.01 || std::abs(p.y() - 6) < 0.01) && p.x() > -0.01 && p.x() < 10.01;
        const bool pillar = std::abs(p.x() - 6) < 0.2 && std::abs(p.y() - 3) < 0.2;
        cells[static_cast<size_t>(r) * g.width + c] =
            wall || wall2 || pillar ? OccupancyMap::kOccupied : inside ? OccupancyMap::kFree : OccupancyMap::kUnknown;
      }
    }
    auto m = std::make_shared<SharedMap>();
    m->map = OccupancyMap(g, std::move(cells));
    m->field = DistanceField(m->map);
    return m;
  }();
  return map;
}

// A scan of the room from `pose` (cast on the grid), 361 beams over 270 deg, mount 0.2 m ahead.
LaserScan scan_from(const Pose2& pose, int beams = 361) {
  LaserScan s;
  s.sensor_pose = Pose2(0.2, 0.0, 0.0).to_isometry();
  s.angle_min = static_cast<float>(-0.75 * M_PI);
  s.angle_increment = static_cast<float>(1.5 * M_PI / (beams - 1));
  s.range_min = 0.05f;
  s.range_max = 8.0f;
  const Pose2 sensor = pose * Pose2(0.2, 0.0, 0.0);
  for (int i = 0; i < beams; ++i) {
    const auto r = cast(room()->map, {sensor.x, sensor.y}, sensor.theta + s.angle(i), 8.0);
    s.ranges.push_back(r ? static_cast<float>(*r) : std::numeric_limits<float>::infinity());
  }
  return s;
}

TEST(GridMclScan, PicksBeamsAsAmclAndReadsNoReturns) {
  LaserModelConfig config;
  config.max_beams = 60;
  LaserScan s = scan_from(Pose2(2, 2, 0));
  const PreparedScan prepared = prepare_scan(s, config);
  EXPECT_EQ(prepared.range.size(), 61u) << "step (361 - 1) / (60 - 1) = 6: beams 0, 6, ..., 360";
  EXPECT_NEAR(prepared.bearing[1], s.angle(6), 1e-6);
  EXPECT_DOUBLE_EQ(prepared.z_max, 8.0) << "the smaller of laser_max_range and the scan's";
  ASSERT_EQ(prepared.hit[0] + prepared.hit[1], 2);
  // REP 117: +inf and a max-range reading are no return (a max reading for the beam model); NaN,
  // zero (below range_min) and -inf (too close) say nothing and are left out.
  const LaserScan clean = s;
  s.ranges[0] = std::numeric_limits<float>::infinity();
  s.ranges[6] = 8.0f;  // range_max
  s.ranges[12] = std::numeric_limits<float>::quiet_NaN();
  s.ranges[18] = 0.0f;
  s.ranges[24] = -std::numeric_limits<float>::infinity();
  const PreparedScan with_misses = prepare_scan(s, config);
  ASSERT_EQ(with_misses.range.size(), prepared.range.size() - 3);
  EXPECT_EQ(with_misses.hit[0], 0);
  EXPECT_EQ(with_misses.hit[1], 0);
  EXPECT_DOUBLE_EQ(with_misses.range[0], 8.0);
  EXPECT_DOUBLE_EQ(with_misses.range[1], 8.0);
  EXPECT_NEAR(with_misses.bearing[2], s.angle(30), 1e-6) << "beams 12, 18 and 24 skipped";
  EXPECT_EQ(with_misses.hits(), prepared.hits() - 5);
  // An upside-down laser (rolled by pi) sees its beams mirrored in base_link.
  LaserScan flipped_scan = clean;
  flipped_scan.sensor_pose = Pose2(0.2, 0.0, 0.0).to_isometry() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());
  const PreparedScan flipped = prepare_scan(flipped_scan, config);
  EXPECT_NEAR(flipped.bearing[5], -s.angle(30), 1e-6);
}

// Random poses put many beam ends outside the room, in its unknown cells and beyond the map.
TEST(GridMclLikelihoodField, TablePathMatchesTheDirectFormula) {
  for (const double unknown_occupancy : {0.0, 0.5}) {
  for (LaserModelType type : {LaserModelType::kLikelihoodField, LaserModelType::kLikelihoodFieldProb}) {
    SCOPED_TRACE("unknown_occupancy " + std::to_string(unknown_occupancy));
    LaserModelConfig config;
    config.type = type;
    config.z_hit = 0.9;
    config.z_rand = 0.1;
    config.sigma_hit = 0.15;
    config.unknown_occupancy = unknown_occupancy;
    LaserModel model(room(), config);
    const PreparedScan scan = prepare_scan(scan_from(Pose2(3.0, 2.5, 0.4)), config);
    model.prepare(scan);
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> x(-1, 11), y(-1, 7), yaw(-M_PI, M_PI);
    std::vector<PoseParticle> particles(500);
    for (PoseParticle& p : particles) p.pose = Pose2(x(rng), y(rng), yaw(rng));
    particles[0].pose = Pose2(3.0, 2.5, 0.4);  // the truth
    std::vector<double> factor(particles.size()), measure(particles.size());
    model.factors(particles, 0, particles.size(), scan, factor.data(), measure.data());
    int differing = 0;
    for (size_t i = 0; i < particles.size(); ++i) {
      double direct_measure = 0.0;
      const double direct = model.factor_direct(particles[i].pose, scan, &direct_measure);
      // The fast path computes beam ends in float cell units: a rare end on a cell boundary may
      // fall in the neighbour cell; otherwise the two agree to float rounding.
      if (std::abs(factor[i] - direct) > 1e-4 * (1.0 + std::abs(direct))) ++differing;
      EXPECT_NEAR(factor[i], direct, 0.05 * (1.0 + std::abs(direct))) << i;
      EXPECT_NEAR(measure[i], direct_measure, 0.02) << i;
    }
    EXPECT_LE(differing, 5);
    // The truth beats every random pose.
    for (size_t i = 1; i < particles.size(); ++i) EXPECT_GT(factor[0], factor[i]);
  }
  }
}

// The state's see-through share skips free space over the distance field; the direct formula
// casts every ray cell by cell (OccupancyMap::cast) and asks for an occupied cell more than the
// margin (0.3 m + 10 % of the range) before the return's end. They agree on every beam.
TEST(GridMclSeeThrough, MarchOverTheFieldAgreesWithCastingEveryBeam) {
  LaserModelConfig config;
  config.max_beams = 361;
  const LaserModel model(room(), config);
  const Pose2 truth(3.0, 2.5, 0.4);
  const PreparedScan scan = prepare_scan(scan_from(truth), config);
  const double margin = 0.3, fraction = 0.1;
  const auto direct = [&](const Pose2& pose) {
    const Eigen::Vector2d sensor = pose.transform(scan.sensor_position);
    size_t hits = 0, through = 0;
    for (size_t k = 0; k < scan.range.size(); ++k) {
      if (!scan.hit[k]) continue;
      ++hits;
      const double before = (1.0 - fraction) * scan.range[k] - margin;
      if (before > 0.0 && cast(room()->map, sensor, pose.theta + scan.bearing[k], before)) ++through;
    }
    return static_cast<double>(through) / static_cast<double>(hits);
  };
  EXPECT_EQ(model.see_through(truth, scan, margin, fraction), 0.0);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(0.5, 9.5), y(0.5, 5.5), yaw(-M_PI, M_PI);
  double mean = 0.0;
  const int poses = 300;
  for (int i = 0; i < poses; ++i) {
    const Pose2 pose(x(rng), y(rng), yaw(rng));
    const double share = direct(pose);
    const double marched = model.see_through(pose, scan, margin, fraction);
    EXPECT_DOUBLE_EQ(marched, share) << i;
    mean += marched / poses;
  }
  EXPECT_GT(mean, 0.2) << "wrong poses see through the room's walls";
}

// The by-hand cases' field (z_hit 0.8, z_rand 0.2, sigma_hit 0.1) and their one beam: 1 m
// straight ahead, z_max 8 m.
LaserModelConfig by_hand_field() {
  LaserModelConfig config;
  config.type = LaserModelType::kLikelihoodField;
  config.z_hit = 0.8;
  config.z_rand = 0.2;
  config.sigma_hit = 0.1;
  return config;
}

PreparedScan one_beam_ahead() {
  PreparedScan scan;
  scan.z_max = 8.0;
  scan.range = {1.0};
  scan.bearing = {0.0};
  scan.hit = {1};
  scan.end = {Eigen::Vector2d(1.0, 0.0)};
  return scan;
}

TEST(GridMclLikelihoodField, OneBeamByHand) {
  LaserModel model(room(), by_hand_field());
  const PreparedScan scan = one_beam_ahead();
  model.prepare(scan);
  // From (8.9, 1, 0) the beam ends at (9.9, 1), a cell centre 0.1 m from the wall's (x = 10).
  const double d = 0.1;
  const double pz = 0.8 * std::exp(-d * d / (2 * 0.1 * 0.1)) + 0.2 / 8.0;
  EXPECT_NEAR(model.factor_direct(Pose2(8.9, 1.0, 0.0), scan), 1.0 + pz * pz * pz, 1e-9);
  // Beyond laser_likelihood_max_dist (and off the map) the field saturates.
  const double far = 0.8 * std::exp(-2.0 * 2.0 / (2 * 0.1 * 0.1)) + 0.2 / 8.0;
  EXPECT_NEAR(model.factor_direct(Pose2(50.0, 50.0, 0.0), scan), 1.0 + far * far * far, 1e-12);
  EXPECT_NEAR(model.fit(Pose2(8.9, 1.0, 0.0), scan, 0.1), 1.0, 1e-12);
  EXPECT_NEAR(model.fit(Pose2(5.0, 1.0, 0.0), scan, 0.1), 0.0, 1e-12);
}

// unknown_occupancy u: a beam ending in an unknown cell is a wall there with probability u,
// pz = u (z_hit + z_rand / z_max) + (1 - u) pz(d); beyond the map d saturates.
TEST(GridMclLikelihoodField, ABeamEndingInUnknownSpaceByHand) {
  LaserModelConfig config = by_hand_field();
  config.unknown_occupancy = 0.5;
  LaserModel model(room(), config);
  const PreparedScan scan = one_beam_ahead();
  model.prepare(scan);
  const auto known = [](double d) { return 0.8 * std::exp(-d * d / (2 * 0.1 * 0.1)) + 0.2 / 8.0; };
  const auto cube = [](double x) { return x * x * x; };
  // From (8, -0.35) the beam ends at (9, -0.35), an unknown cell 0.35 m below the wall y = 0.
  const double below = 0.5 * (0.8 + 0.2 / 8.0) + 0.5 * known(0.35);
  EXPECT_NEAR(model.factor_direct(Pose2(8.0, -0.35, 0.0), scan), 1.0 + cube(below), 1e-9);
  // Beyond the map: unknown, the field saturated.
  const double beyond = 0.5 * (0.8 + 0.2 / 8.0) + 0.5 * known(2.0);
  EXPECT_NEAR(model.factor_direct(Pose2(50.0, 50.0, 0.0), scan), 1.0 + cube(beyond), 1e-12);
  // A known free cell as before: the field at the end (6, 1).
  double direct_known = 0.0;
  model.factor_direct(Pose2(5.0, 1.0, 0.0), scan, &direct_known);
  int row = 0, col = 0;
  ASSERT_TRUE(room()->map.geometry().index_of({6.0, 1.0}, row, col));
  EXPECT_NEAR(direct_known, known(room()->field.distance(row, col)), 1e-9);
  // The fast path agrees.
  std::vector<PoseParticle> particles(2);
  particles[0].pose = Pose2(8.0, -0.35, 0.0);
  particles[1].pose = Pose2(50.0, 50.0, 0.0);
  double factor[2], measure[2];
  model.factors(particles, 0, 2, scan, factor, measure);
  EXPECT_NEAR(factor[0], 1.0 + cube(below), 1e-5);
  EXPECT_NEAR(factor[1], 1.0 + cube(beyond), 1e-5);
  // With 0 (AMCL) an unknown cell is scored by its distance to the nearest obstacle.
  config.unknown_occupancy = 0.0;
  LaserModel amcl(room(), config);
  amcl.prepare(scan);
  EXPECT_NEAR(amcl.factor_direct(Pose2(8.0, -0.35, 0.0), scan), 1.0 + cube(known(0.35)), 1e-9);
  amcl.factors(particles, 0, 2, scan, factor, measure);
  EXPECT_NEAR(factor[0], 1.0 + cube(known(0.35)), 1e-5);
}

// The state's scan fit with known_only: a return ending away from any obstacle in unknown space
// it reached without passing a wall says nothing (the map lacks that part); one that passed
// through a wall of the map still disagrees.
TEST(GridMclScanFit, ReturnsIntoUnknownSpaceCountOnlyThroughAWall) {
  LaserModelConfig config;
  const LaserModel model(room(), config);
  const auto two_beams = [](double bearing0, double range0, double bearing1, double range1) {
    PreparedScan scan;
    scan.z_max = 8.0;
    scan.range = {range0, range1};
    scan.bearing = {bearing0, bearing1};
    scan.hit = {1, 1};
    for (size_t k = 0; k < 2; ++k) {
      scan.end.push_back(scan.range[k] * Eigen::Vector2d(std::cos(scan.bearing[k]), std::sin(scan.bearing[k])));
    }
    return scan;
  };
  // Below the room at (8, -0.35): up to the wall (fits), and along it into unknown space.
  const PreparedScan outside = two_beams(M_PI / 2, 0.35, 0.0, 1.0);
  EXPECT_NEAR(model.fit(Pose2(8.0, -0.35, 0.0), outside, 0.1), 0.5, 1e-12);
  EXPECT_NEAR(model.fit(Pose2(8.0, -0.35, 0.0), outside, 0.1, true), 1.0, 1e-12);
  // Inside at (8, 0.35): down to the wall (fits), and through it into the unknown cells below.
  const PreparedScan through = two_beams(-M_PI / 2, 0.35, -M_PI / 2, 0.7);
  EXPECT_NEAR(model.fit(Pose2(8.0, 0.35, 0.0), through, 0.1), 0.5, 1e-12);
  EXPECT_NEAR(model.fit(Pose2(8.0, 0.35, 0.0), through, 0.1, true), 0.5, 1e-12);
  // Nothing counted: no fit.
  const PreparedScan lost = two_beams(0.0, 1.0, 0.0, 1.2);
  EXPECT_NEAR(model.fit(Pose2(8.0, -0.35, 0.0), lost, 0.1, true), 0.0, 1e-12);
}

// The room's map without its walls at x = 10 and y = 6 (unknown there, as a map that never saw
// them); the world (scan_from) keeps them.
std::shared_ptr<const SharedMap> room_missing_two_walls() {
  static const std::shared_ptr<const SharedMap> map = [] {
    const OccupancyMap& full = room()->map;
    const GridGeometry& g = full.geometry();
    std::vector<int8_t> cells = full.cells();
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) {
        const Eigen::Vector2d p = g.center_of(r, c);
        if (full.at(r, c) == OccupancyMap::kOccupied && (p.x() > 9.9 || p.y() > 5.9)) {
          cells[static_cast<size_t>(r) * g.width + c] = OccupancyMap::kUnknown;
        }
      }
    }
    auto m = std::make_shared<SharedMap>();
    m->map = OccupancyMap(g, std::move(cells));
    m->field = DistanceField(m->map);
    return m;
  }();
  return map;
}

// Where the map lacks most of what the scan sees, the filter says uncertain (its pose rests on
// odometry) and names why, never lost: the returns into the part the map lacks neither fit nor
// misfit. With the whole map the same scan tracks.
TEST(GridMclState, ReturnsWhereTheMapKnowsNothingMakeItUncertainNotLost) {
  Config config;
  config.laser.type = LaserModelType::kLikelihoodFieldProb;
  config.laser.unknown_occupancy = 0.5;
  const Pose2 truth(8.5, 4.5, 0.8);
  const LaserScan scan = scan_from(truth);
  for (const bool whole : {true, false}) {
    SCOPED_TRACE(whole ? "the whole map" : "two walls missing");
    GridParticleFilter filter(config, whole ? room() : room_missing_two_walls());
    filter.set_pose(truth, Eigen::Vector3d(0.02, 0.02, 0.01).cwiseAbs2().asDiagonal());
    const CorrectionReport report = filter.correct(scan, Pose2());
    ASSERT_TRUE(report.updated);
    EXPECT_GT(report.fit, 0.9) << "every return the map can judge fits";
    if (whole) {
      EXPECT_GT(report.known, 0.99);
      EXPECT_EQ(filter.assessment().state, LocalizationState::kTracking) << filter.assessment().reason;
    } else {
      EXPECT_LT(report.known, config.state.tracking_min_known);
      EXPECT_EQ(filter.assessment().state, LocalizationState::kUncertain) << filter.assessment().reason;
      EXPECT_NE(filter.assessment().reason.find("the map knows where"), std::string::npos) << filter.assessment().reason;
    }
  }
}

TEST(GridMclBeamModel, MixtureByHandAndTheTruthWins) {
  LaserModelConfig config;
  config.type = LaserModelType::kBeam;
  config.z_hit = 0.7;
  config.z_short = 0.1;
  config.z_max = 0.1;
  config.z_rand = 0.1;
  config.sigma_hit = 0.1;
  config.lambda_short = 0.5;
  LaserModel model(room(), config);
  PreparedScan scan;
  scan.z_max = 8.0;
  scan.sensor_position = Eigen::Vector2d::Zero();
  scan.bearing = {0.0, M_PI / 2};
  scan.range = {0.8, 8.0};  // a short reading against the wall 1.0 m away; a max reading
  scan.hit = {1, 0};
  scan.end = {Eigen::Vector2d(0.8, 0), Eigen::Vector2d(0, 0)};
  // From (9.0, 5.0, 0): the wall's cell centre at x = 10 -> expected 1.0 m; up: the wall at y = 6
  // (expected 1.0 m) but the reading is z_max.
  const double z = 0.8 - 1.0;
  const double short_pz = 0.7 * std::exp(-z * z / 0.02) + 0.1 * 0.5 * std::exp(-0.5 * 0.8) + 0.1 / 8.0;
  const double max_pz = 0.7 * std::exp(-7.0 * 7.0 / 0.02) + 0.1;
  EXPECT_NEAR(model.factor_direct(Pose2(9.0, 5.0, 0.0), scan), 1.0 + std::pow(short_pz, 3) + std::pow(max_pz, 3), 1e-9);
  // On a full scan the true pose weighs more than poses 0.3 m or 0.1 rad off.
  config.max_beams = 30;
  LaserModel full(room(), config);
  const Pose2 truth(4.0, 2.0, 0.3);
  const PreparedScan s = prepare_scan(scan_from(truth), config);
  const double at_truth = full.factor_direct(truth, s);
  EXPECT_GT(at_truth, full.factor_direct(Pose2(4.3, 2.0, 0.3), s));
  EXPECT_GT(at_truth, full.factor_direct(Pose2(4.0, 2.0, 0.4), s));
}

// The sampled motion of many particles from one pose: mean and spread as the model states.
void expect_spread(MotionModelType type, const MotionNoise& noise, const Pose2& before, const Pose2& after,
                   const Eigen::Vector3d& along_across_yaw_variance) {
  const MotionModel model(type, noise);
  std::mt19937_64 rng(9);
  const Pose2 start(1.0, 2.0, 0.7);
  std::vector<PoseParticle> particles(200000, PoseParticle{start, 1.0});
  model.sample(particles, before, after, rng);
  const Pose2 expected = start * (before.inverse() * after);
  // Errors in the expected pose's frame: along, across, yaw.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d variance = Eigen::Vector3d::Zero();
  for (const PoseParticle& p : particles) {
    const Pose2 e = expected.inverse() * p.pose;
    const Eigen::Vector3d v(e.x, e.y, normalize_angle(e.theta));
    mean += v / particles.size();
    variance += v.cwiseAbs2() / particles.size();
  }
  const double n = static_cast<double>(particles.size());
  for (int k = 0; k < 3; ++k) {
    // The mean to first order: driving through a noisy heading shortens the step by E[rot^2] / 2.
    EXPECT_NEAR(mean[k], 0.0, 5.0 * std::sqrt(along_across_yaw_variance[k] / n) + 0.6 * along_across_yaw_variance[k]) << k;
    EXPECT_NEAR(variance[k], along_across_yaw_variance[k], 0.05 * along_across_yaw_variance[k] + 1e-8) << k;
  }
}

TEST(GridMclMotionModel, DifferentialSpreadFollowsTheAlphas) {
  const MotionNoise a{0.02, 0.01, 0.01, 0.03, 0.0};
  // 1 m straight ahead: rot1 = rot2 = 0, trans = 1. Along: alpha3; across: trans^2 alpha2 (rot1);
  // yaw: rot1 + rot2, each alpha2 (to first order: the across spread carries E[trans^2] = 1.01).
  expect_spread(MotionModelType::kDifferential, a, Pose2(0, 0, 0), Pose2(1, 0, 0), {0.01, 0.01, 0.02});
  // Driving backwards 1 m counts as straight (AMCL's corrected model), not as two half turns.
  expect_spread(MotionModelType::kDifferential, a, Pose2(0, 0, 0), Pose2(-1, 0, 0), {0.01, 0.01, 0.02});
  const MotionModel model(MotionModelType::kDifferential, a);
  // A turn on the spot of 0.5 rad: rot2 = 0.5 only (rot1 = 0 below 1 cm of travel).
  const Eigen::Vector3d s = model.stddev(Pose2(0, 0, 0), Pose2(0, 0, 0.5));
  EXPECT_NEAR(s[0], 0.0, 1e-12);
  EXPECT_NEAR(s[1], std::sqrt(0.03 * 0.25), 1e-12);
  EXPECT_NEAR(s[2], std::sqrt(0.02 * 0.25), 1e-12);
}

TEST(GridMclMotionModel, OmnidirectionalSpreadFollowsTheAlphas) {
  const MotionNoise a{0.02, 0.01, 0.04, 0.03, 0.05};
  // 1 m sideways (strafing left): along the translation alpha3, across it alpha5, yaw alpha4.
  // In the expected pose's frame (heading unchanged) the translation is across: x <-> y swapped.
  expect_spread(MotionModelType::kOmnidirectional, a, Pose2(0, 0, 0), Pose2(0, 1, 0), {0.05, 0.04, 0.03});
}

}  // namespace
