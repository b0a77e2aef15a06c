// The association strategies on hand-made ambiguous frames (ENU model, identity attitude, so a
// detection's body position is its ENU offset): two same-class signs inside the gate, a missed
// detection, a false one; and input the filter rejects. Then a short simulated drive per strategy.
#include <gtest/gtest.h>

#include "locd/feature_ekf/landmark_ekf_filter.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sim_feature_ekf/landmark_filter_run.hpp"

using namespace locd;
using namespace locd::feature_ekf;

namespace test = locd::sim::road_signs;

namespace {

// Signs in ENU metres about the centre: A and B share class "x", 8 m apart across the road;
// C is the only "y"; D an "x" far away.
const OperatingArea kArea = OperatingArea::centred_at(36.1 * M_PI / 180, 129.37 * M_PI / 180, 0.0);

LandmarkDatabase database() {
  std::vector<Landmark> landmarks;
  auto add = [&](const char* id, const char* cls, Eigen::Vector2d enu) {
    const Eigen::Vector2d g = kArea.to_geodetic(enu) * 180.0 / M_PI;
    landmarks.push_back({id, cls, g.x(), g.y()});
  };
  add("A", "x", {20.0, 5.0});
  add("B", "x", {20.0, -3.0});
  add("C", "y", {30.0, -20.0});
  add("D", "x", {400.0, 400.0});
  return LandmarkDatabase(landmarks, "test");
}

// Truth: the vehicle is at (0, 0). The filter believes (0, -5) +- 4 m, so sign B's hypothesis
// (residual 2 m) is nearer than the true A's (5 m): the paper's failure case (its Fig. 7).
LandmarkEkfFilter filter(AssociationStrategy strategy, double believed_north = -5.0) {
  LandmarkEkfConfig c;
  c.model = LandmarkModelKind::kEnu;
  c.association.strategy = strategy;
  c.centre_deg = Eigen::Vector2d(36.1, 129.37);
  c.detection_stddev = 1.0;
  c.initial_position = {0.0, believed_north};
  c.initial_position_stddev = 4.0;
  LandmarkEkfFilter f(c, database());
  Imu imu;
  imu.header.stamp_ns = 1;
  f.apply_imu(imu);
  return f;
}

LandmarkDetections frame(std::vector<std::pair<std::string, Eigen::Vector2d>> detections, int64_t stamp = 2) {
  LandmarkDetections d;
  d.header.stamp_ns = stamp;
  for (const auto& [label, offset] : detections) d.detections.push_back({label, {offset.x(), offset.y(), 0.0}, Eigen::Matrix3d::Identity()});
  return d;
}

const Eigen::Vector2d kSeenA(20.0, 5.0), kSeenC(30.0, -20.0);

std::string input_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

}  // namespace

TEST(LandmarkAssociationStrategies, NearestNeighbourTakesTheNearerWrongSign) {
  LandmarkEkfFilter f = filter(AssociationStrategy::kNearestNeighbor);
  const LandmarkUpdateReport r = f.update(frame({{"x", kSeenA}}));
  ASSERT_EQ(r.detections.size(), 1u);
  EXPECT_EQ(r.detections[0].hypotheses, 3u);  // A, B, D
  EXPECT_EQ(r.detections[0].in_gate, 2u);     // A and B
  EXPECT_EQ(f.database()[r.detections[0].landmark].id, "B");
  EXPECT_LT(f.position_enu().y(), -5.0);  // pulled further from the truth
}

TEST(LandmarkAssociationStrategies, KnownIdTakesTheNamedSign) {
  LandmarkEkfFilter f = filter(AssociationStrategy::kKnownId);
  const LandmarkUpdateReport r = f.update(frame({{"x#A", kSeenA}}));
  EXPECT_EQ(f.database()[r.detections[0].landmark].id, "A");
  EXPECT_EQ(r.detections[0].hypotheses, 3u);
  EXPECT_GT(f.position_enu().y(), -1.0);
  // Without an id (a false detection in an oracle stream) nothing is associated.
  const Eigen::Vector2d before = f.position_enu();
  EXPECT_FALSE(f.update(frame({{"x", kSeenA}}, 3)).detections[0].applied);
  EXPECT_EQ(f.position_enu(), before);
}

TEST(LandmarkAssociationStrategies, JcbbResolvesTheAmbiguityWithASecondDetection) {
  // A and C seen together: only A is jointly compatible with C (both say the vehicle is at (0, 0));
  // nearest neighbour decides each alone and still takes B.
  LandmarkEkfFilter nn = filter(AssociationStrategy::kNearestNeighbor);
  LandmarkEkfFilter jcbb = filter(AssociationStrategy::kJcbb);
  const LandmarkUpdateReport r_nn = nn.update(frame({{"x", kSeenA}, {"y", kSeenC}}));
  const LandmarkUpdateReport r_jcbb = jcbb.update(frame({{"x", kSeenA}, {"y", kSeenC}}));
  EXPECT_EQ(nn.database()[r_nn.detections[0].landmark].id, "B");
  EXPECT_EQ(jcbb.database()[r_jcbb.detections[0].landmark].id, "A");
  EXPECT_EQ(jcbb.database()[r_jcbb.detections[1].landmark].id, "C");
  EXPECT_LT(jcbb.position_enu().norm(), 1.0);
  EXPECT_GT(nn.position_enu().norm(), 1.0);
}

TEST(LandmarkAssociationStrategies, JcbbUsesEachSignOnce) {
  // Two "x" detections at A's and B's places: each gets its own sign.
  LandmarkEkfFilter f = filter(AssociationStrategy::kJcbb, -1.0);
  const LandmarkUpdateReport r = f.update(frame({{"x", kSeenA}, {"x", Eigen::Vector2d(20.0, -3.0)}}));
  ASSERT_TRUE(r.detections[0].applied && r.detections[1].applied);
  EXPECT_EQ(f.database()[r.detections[0].landmark].id, "A");
  EXPECT_EQ(f.database()[r.detections[1].landmark].id, "B");
}

TEST(LandmarkAssociationStrategies, PdaWeighsBothSignsAndStaysUncertain) {
  LandmarkEkfFilter nn = filter(AssociationStrategy::kNearestNeighbor);
  LandmarkEkfFilter pda = filter(AssociationStrategy::kPda);
  nn.update(frame({{"x", kSeenA}}));
  const LandmarkUpdateReport r = pda.update(frame({{"x", kSeenA}}));
  ASSERT_TRUE(r.detections[0].applied);
  EXPECT_EQ(pda.database()[r.detections[0].landmark].id, "B");  // the more likely one...
  EXPECT_LT(r.detections[0].weight, 0.95);                      // ...but not certain
  EXPECT_GT(r.detections[0].weight, 0.5);
  // The mixture lies between the two hypotheses and keeps their spread in the covariance.
  EXPECT_GT(pda.position_enu().y(), nn.position_enu().y());
  EXPECT_GT(pda.covariance_enu()(1, 1), 2.0 * nn.covariance_enu()(1, 1));
}

TEST(LandmarkAssociationStrategies, PdaWeightsAddUpWithTheFalseHypothesis) {
  std::vector<DetectionHypotheses> frame_hypotheses(1);
  frame_hypotheses[0].S = Eigen::Matrix2d::Identity();
  frame_hypotheses[0].hypotheses = {{0, {0.5, 0.0}, 0}, {1, {0.0, 1.5}, 0}, {2, {9.0, 9.0}, 0}};
  LandmarkAssociationConfig config;
  config.strategy = AssociationStrategy::kPda;
  const AssociationDecision d = LandmarkAssociation(config).associate(frame_hypotheses, Eigen::Matrix2d::Zero())[0];
  ASSERT_EQ(d.weights.size(), 2u);  // the third is outside the gate
  double total = d.false_weight;
  for (const auto& [index, beta] : d.weights) total += beta;
  EXPECT_NEAR(total, 1.0, 1e-12);
  EXPECT_EQ(d.landmark, 0);
  // beta_1 / beta_2 = exp(-(0.25 - 2.25) / 2): the likelihood ratio of eq. 23.
  EXPECT_NEAR(d.weights[0].second / d.weights[1].second, std::exp(1.0), 1e-9);
  EXPECT_NEAR(LandmarkAssociation(config).gate_threshold(), 11.9, 1e-6);
}

TEST(LandmarkAssociationStrategies, MissedAndFalseDetectionsLeaveTheStateAlone) {
  for (AssociationStrategy s : {AssociationStrategy::kNearestNeighbor, AssociationStrategy::kJcbb, AssociationStrategy::kPda}) {
    LandmarkEkfFilter f = filter(s, 0.0);
    const Eigen::Vector2d before = f.position_enu();
    // A frame with nothing in it (every sign missed).
    EXPECT_TRUE(f.update(frame({}, 2)).detections.empty());
    // A "y" where no "y" stands: outside every gate.
    const LandmarkUpdateReport r = f.update(frame({{"y", Eigen::Vector2d(-15.0, 25.0)}}, 3));
    EXPECT_FALSE(r.detections[0].applied) << association_strategy_name(s);
    EXPECT_EQ(r.detections[0].in_gate, 0u);
    EXPECT_EQ(r.detections[0].landmark, -1);
    EXPECT_EQ(f.position_enu(), before) << association_strategy_name(s);
    // The next true detection still works.
    EXPECT_TRUE(f.update(frame({{"x", kSeenA}}, 4)).detections[0].applied) << association_strategy_name(s);
  }
}

TEST(LandmarkAssociationStrategies, BadInputIsRejectedAndTheFilterGoesOn) {
  LandmarkEkfFilter f = filter(AssociationStrategy::kPda, 0.0);
  const std::string unknown = input_error([&] { f.update(frame({{"stop", kSeenA}})); });
  EXPECT_NE(unknown.find("class 'stop' is not in the landmark database; known: x, y"), std::string::npos) << unknown;
  // NaN detections and attitudes never reach the filter (the bridge refuses them:
  // tests/sdk/validate_test.cpp); a sample not after the previous one predicts nothing.
  Imu late;
  late.header.stamp_ns = 0;
  const Eigen::Vector4d before = f.state();
  EXPECT_FALSE(f.apply_imu(late));
  EXPECT_EQ(f.state(), before);
  EXPECT_TRUE(f.update(frame({{"x", kSeenA}}, 6)).detections[0].applied);

  LandmarkEkfConfig c;
  c.model = LandmarkModelKind::kEnu;
  LandmarkEkfFilter fresh(c, database());
  EXPECT_NE(input_error([&] { fresh.update(frame({{"x", kSeenA}})); }).find("before any imu"), std::string::npos);
  c.association.strategy = AssociationStrategy::kKnownId;
  LandmarkEkfFilter known(c, database());
  Imu imu;
  imu.header.stamp_ns = 1;
  known.apply_imu(imu);
  EXPECT_NE(input_error([&] { known.update(frame({{"y#A", kSeenA}})); }).find("landmark id 'A' of class 'y'"),
            std::string::npos);
}

// A 150 s drive through the road-sign world: every strategy keeps the error of a few metres.
TEST(LandmarkEkfDrive, EveryStrategyTracksAShortDrive) {
  sim::road_signs::WorldConfig world_config;
  const sim::road_signs::RoadSignWorld world(world_config);
  sim::road_signs::DriveConfig drive;
  drive.duration = 150.0;
  for (AssociationStrategy s : {AssociationStrategy::kKnownId, AssociationStrategy::kNearestNeighbor,
                                AssociationStrategy::kJcbb, AssociationStrategy::kPda}) {
    for (LandmarkModelKind model : {LandmarkModelKind::kGeodetic, LandmarkModelKind::kEnu}) {
      const test::FilterRunResult r = test::run_drive(world, drive, test::config_for(world, s, model), 5, 11, {3.0, -2.0});
      std::vector<double> sorted = r.errors;
      std::sort(sorted.begin(), sorted.end());
      EXPECT_GT(r.applied, 15u);
      EXPECT_LT(sorted[sorted.size() / 2], 4.0) << association_strategy_name(s) << " " << landmark_model_name(model);
      EXPECT_LT(r.max_error(), 25.0) << association_strategy_name(s) << " " << landmark_model_name(model);
    }
  }
}

// Without detections the filter dead-reckons: the error stays near the start offset while the
// IMU model matches the simulated vehicle (no sensor noise), i.e. eq. 7-9 agree with the world.
TEST(LandmarkEkfDrive, DeadReckoningWithExactSensorsFollowsTheTruth) {
  const sim::road_signs::RoadSignWorld world{sim::road_signs::WorldConfig{}};
  sim::road_signs::DriveConfig drive;
  drive.duration = 120.0;
  drive.accelerometer_stddev = 0.0;
  drive.heading_error_rms_deg = drive.tilt_error_rms_deg = 0.0;
  drive.detection_probability = 0.0;
  drive.false_detection_rate = 0.0;
  const test::FilterRunResult r = test::run_drive(world, drive, test::config_for(world, AssociationStrategy::kPda), 5, 1, {0.0, 0.0});
  EXPECT_LT(r.max_error(), 1.0);
  EXPECT_EQ(r.applied, 0u);
}
