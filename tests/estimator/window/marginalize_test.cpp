// marginalizeOldest's choice of factors: a landmark that ends with the oldest keyframe puts all of
// its observations into the prior; one that the window re-anchors puts in only the oldest
// keyframe's own measurements and the link to its new anchor, so that its later measurements
// (the new anchor's LiDAR range among them), which stay in the window, are not counted twice; the
// previous prior always goes on. The terrain plane and the LiDAR ground-plane noise as well.
#include "estimator/window/marginalize.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/so3.hpp"
#include "estimator/window/lidar_gate.hpp"
#include "estimator/window/solve.hpp"
#include "estimator/window/terrain.hpp"
#include "factors/pose_prior_factor.hpp"

namespace ovo::estimator {
namespace {

constexpr TrackId kTrack = 7;

// Three keyframes 0.5 m apart along x (camera = body), one landmark 5 m ahead of the first,
// anchored there and seen by all three. No gyro: besides the landmark's factors only the gauge's
// pose prior touches the oldest keyframe (without it one landmark would say nothing about the
// others' poses once the oldest pose is eliminated).
WindowMap threeKeyframesOneLandmark() {
  WindowMap map;
  const Vec3 p_W(0.3, -0.2, 5.0);
  for (int k = 0; k < 3; ++k) {
    auto kf = std::make_unique<Keyframe>(SE3::Identity());  // no LiDAR in this problem
    kf->id = 10 + k;
    kf->t_ns = k * 500'000'000LL;
    SE3 T = SE3::Identity();
    T.translation() = Vec3(0.5 * k, 0.0, 0.0);
    kf->setPose(T);
    TrackObservation o;
    o.track_id = kTrack;
    o.bearing_C = (p_W - T.translation()).normalized();
    o.age = 1 + 5 * k;
    kf->observations[kTrack] = o;
    map.keyframes.push_back(std::move(kf));
  }
  Landmark lm;
  lm.id = kTrack;
  lm.anchor_kf = 10;
  lm.bearing_anchor_C = p_W.normalized();
  lm.rho[0] = 1.0 / p_W.norm();
  map.landmarks[kTrack] = lm;
  return map;
}

bool keeps(const factors::MarginalizationInfo& info, const Keyframe& kf) {
  const auto& kept = info.keptBlocks();
  return std::find(kept.begin(), kept.end(), kf.p_W_B) != kept.end();
}

WindowModel model() {
  WindowModel m;
  m.use_gyro = false;
  return m;
}

WindowGauge gaugeOnTheOldest() {
  WindowGauge g;
  g.kf_id = 10;
  return g;
}

MarginalizationPlan ending(const std::vector<TrackId>& tracks) {
  MarginalizationPlan plan;
  plan.marginalized.insert(tracks.begin(), tracks.end());
  return plan;
}

// The track re-anchored in keyframe kf_id of the map (link: its old inverse depth into the prior).
MarginalizationPlan reanchored(const WindowMap& map, TrackId track, int kf_id) {
  MarginalizationPlan plan;
  const Keyframe& kf = *map.find(kf_id);
  const Vec3 p_C = kf.pose().inverse() * *map.pointW(track, SE3::Identity());
  plan.reanchor[track] = {kf_id, kf.observations.at(track).bearing_C, 1.0 / p_C.norm()};
  plan.marginalized.insert(track);
  return plan;
}

TEST(MarginalizeOldest, AnEndingLandmarkPutsAllItsObservationsIntoThePrior) {
  WindowMap map = threeKeyframesOneLandmark();
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), ending({kTrack}), nullptr);
  ASSERT_TRUE(info);
  EXPECT_TRUE(keeps(*info, *map.keyframes[1]));
  EXPECT_TRUE(keeps(*info, *map.keyframes[2]));
}

TEST(MarginalizeOldest, AReanchoredLandmarkPutsInOnlyTheLinkToItsNewAnchor) {
  WindowMap map = threeKeyframesOneLandmark();
  const auto info =
      marginalizeOldest(map, model(), gaugeOnTheOldest(), reanchored(map, kTrack, 11), nullptr);
  ASSERT_TRUE(info);
  EXPECT_TRUE(keeps(*info, *map.keyframes[1]));
  // The observation in keyframe 12 stays a factor of the re-anchored landmark, not in the prior.
  EXPECT_FALSE(keeps(*info, *map.keyframes[2]));
}

TEST(MarginalizeOldest, ALandmarkNotSelectedIsDropped) {
  WindowMap map = threeKeyframesOneLandmark();
  // Only the gauge's prior on the oldest pose is left: nothing about the other keyframes.
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), {}, nullptr);
  EXPECT_TRUE(!info || (!keeps(*info, *map.keyframes[1]) && !keeps(*info, *map.keyframes[2])));
}

// A landmark that ends with the oldest keyframe without going into the prior takes all its
// measurements with it, also those on its inverse depth alone (the anchor's own LiDAR range, its
// camera-height factor): the ledger says they were dropped. They used to have no entry. (The
// window forgets the oldest keyframe's entries right after, as no factor can be built for them
// again: the solution is the same either way; the ledger's account is what this checks.)
TEST(MarginalizeOldest, ADroppedLandmarksFactorsOnItsDepthAloneAreRecordedAsDropped) {
  WindowMap map = threeKeyframesOneLandmark();
  Keyframe& anchor = *map.keyframes.front();
  LidarAssociation a;
  a.track_id = kTrack;
  a.range_m = (*map.pointW(kTrack, SE3::Identity()) - anchor.pose().translation()).norm();
  anchor.lidar.push_back(a);
  Landmark& lm = map.landmarks.at(kTrack);
  lm.on_ground = true;
  lm.ground_up_C = Vec3(0.0, -1.0, 0.0);
  WindowModel m = model();
  m.camera_height_m = 1.0;
  FactorLedger ledger;
  marginalizeOldest(map, m, gaugeOnTheOldest(), {}, &ledger);
  EXPECT_EQ(ledger.fate({FactorKind::kLidar, kTrack, 10}), FactorLedger::Fate::kDropped);
  EXPECT_EQ(ledger.fate({FactorKind::kGround, kTrack, 10}), FactorLedger::Fate::kDropped);
  EXPECT_EQ(ledger.fate({FactorKind::kBearing, kTrack, 11}), FactorLedger::Fate::kDropped);
  EXPECT_EQ(ledger.fate({FactorKind::kBearing, kTrack, 12}), FactorLedger::Fate::kDropped);
}

// The LiDAR range that the new anchor of a re-anchored landmark measures stays in the window: the
// prior takes the gauge's pose prior, the oldest keyframe's own sighting and range, and the link
// sighting (4 blocks), and after re-anchoring the window builds the new anchor's range against the
// new landmark. Before the ledger the prior took that range too, and the window built it again.
TEST(MarginalizeOldest, TheNewAnchorsLidarRangeIsCountedOnceInTheWindow) {
  WindowMap map = threeKeyframesOneLandmark();
  for (auto& kf : map.keyframes) {
    LidarAssociation a;
    a.track_id = kTrack;
    a.range_m = (*map.pointW(kTrack, SE3::Identity()) - kf->pose().translation()).norm();
    kf->lidar.push_back(a);
  }
  FactorLedger ledger;
  const MarginalizationPlan plan = reanchored(map, kTrack, 11);
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), plan, &ledger);
  ASSERT_TRUE(info);
  // The gauge's pose prior, the oldest's range, the link sighting (the oldest's own sighting is
  // the anchor: no factor).
  int in_prior = 0;
  for (const auto& [key, fate] : ledger.entries()) in_prior += fate == FactorLedger::Fate::kPrior;
  EXPECT_EQ(in_prior, 3);
  EXPECT_EQ(ledger.fate({FactorKind::kLidar, kTrack, 10}), FactorLedger::Fate::kPrior);
  EXPECT_EQ(ledger.fate({FactorKind::kBearing, kTrack, 11}), FactorLedger::Fate::kPrior);
  EXPECT_FALSE(ledger.fate({FactorKind::kLidar, kTrack, 11}));
  EXPECT_FALSE(ledger.fate({FactorKind::kLidar, kTrack, 12}));
  EXPECT_FALSE(ledger.fate({FactorKind::kBearing, kTrack, 12}));

  map.keyframes.pop_front();
  ledger.forgetBefore(11);
  reanchorLandmarks(map, 10, plan);
  std::vector<Keyframe*> kfs = {map.keyframes[0].get(), map.keyframes[1].get()};
  int lidar_11 = 0, lidar_12 = 0, bearing_12 = 0;
  for (const auto& f : buildFactors(kfs, map.landmarks, model(), {}, &ledger)) {
    lidar_11 += f.kind == FactorKind::kLidar && f.kf_id == 11;
    lidar_12 += f.kind == FactorKind::kLidar && f.kf_id == 12;
    bearing_12 += f.kind == FactorKind::kBearing && f.kf_id == 12;
  }
  EXPECT_EQ(lidar_11, 1);
  EXPECT_EQ(lidar_12, 1);
  EXPECT_EQ(bearing_12, 1);
}

// A previous prior that touches none of the oldest keyframe's states goes into the new prior all
// the same (without a gyro nothing else may link it): it used to be lost.
// A ground landmark gets its camera-height factor only at an inverse depth that is a distance: at
// 1e-9 /m (1e6 km, for the ground at infinity) the factor's 1 / rho would fail the solve at its
// start point.
TEST(BuildFactors, AGroundLandmarkAtAnInverseDepthOfNoDistanceGetsNoHeightFactor) {
  WindowMap map = threeKeyframesOneLandmark();
  WindowModel m = model();
  m.camera_height_m = 1.0;
  Landmark& lm = map.landmarks.at(kTrack);
  lm.on_ground = true;
  lm.ground_up_C = Vec3(0.0, -1.0, 0.0);
  std::vector<Keyframe*> kfs;
  for (auto& kf : map.keyframes) kfs.push_back(kf.get());
  const auto ground = [&] {
    const auto f = buildFactors(kfs, map.landmarks, m, gaugeOnTheOldest());
    return std::count_if(f.begin(), f.end(),
                         [](const FactorSpec& s) { return s.kind == FactorKind::kGround; });
  };
  EXPECT_EQ(ground(), 1);
  lm.rho[0] = 1e-9;
  EXPECT_EQ(ground(), 0);
}

// With nothing but the gauge's pose prior on the oldest keyframe, no state of the prior would be
// kept and the marginalisation fails: the ledger then says the prior's factors were dropped, not
// that a prior holds them.
TEST(MarginalizeOldest, AFailedMarginalisationRecordsItsFactorsAsDropped) {
  WindowMap map = threeKeyframesOneLandmark();
  map.landmarks.clear();
  FactorLedger ledger;
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), ending({}), &ledger);
  EXPECT_EQ(info, nullptr);
  const auto fate = ledger.fate({FactorKind::kPosePrior, -1, 10});
  ASSERT_TRUE(fate.has_value());
  EXPECT_EQ(*fate, FactorLedger::Fate::kDropped);
  EXPECT_EQ(ledger.recorded(FactorKind::kPosePrior, FactorLedger::Fate::kPrior), 0);
}

TEST(MarginalizeOldest, ThePreviousPriorGoesOnWhenItTouchesNoneOfTheOldestStates) {
  WindowMap map = threeKeyframesOneLandmark();
  Keyframe& kf12 = *map.keyframes[2];
  auto old_prior = std::make_shared<factors::MarginalizationInfo>();
  factors::PosePriorFactor on12(kf12.pose(),
                                factors::PosePriorFactor::gaugeInformation(1e-3, 1e-3, 1e-3));
  old_prior->setQuaternionBlock(kf12.q_W_B);
  ASSERT_TRUE(old_prior->addResidualBlock(&on12, nullptr, {kf12.q_W_B, kf12.p_W_B}, {}));
  ASSERT_TRUE(old_prior->marginalize());
  WindowGauge gauge;  // no pose prior: the old prior and the landmark
  gauge.marginalization = old_prior;
  FactorLedger ledger;
  const auto info = marginalizeOldest(map, model(), gauge, ending({}), &ledger);
  ASSERT_TRUE(info);
  EXPECT_TRUE(keeps(*info, kf12));
  // Its information on keyframe 12's position is all there: 1 / (1 mm)^2 per axis, against some
  // 1e4 / m^2 that the landmark's sightings give.
  const auto& kept = info->keptBlocks();
  const auto sizes = info->keptBlockSizes();
  int offset = 0;
  for (std::size_t k = 0; k < kept.size() && kept[k] != kf12.p_W_B; ++k)
    offset += info->isQuaternion(kept[k]) ? 3 : sizes[k];
  EXPECT_GE(info->priorHessian()(offset, offset), 0.999e6);
}

// Two keyframes 1 m apart on flat ground, each anchoring ground points around it; the gauge holds
// the first. The second's pitch is 1 deg off (as a drifting gyro leaves it) and nothing else sees
// its orientation. The camera-height factors fix each point's depth below its camera; only the
// terrain plane, walked from the first keyframe's, says that the second camera's points must lie
// on the same ground, which brings its pitch back.
struct PitchedSecondKeyframe {
  WindowMap map;
  WindowModel model;
  WindowGauge gauge;
  SE3 truth1 = SE3::Identity();
};

PitchedSecondKeyframe pitchedSecondKeyframe(bool terrain) {
  PitchedSecondKeyframe out;
  WindowModel& m = out.model;
  m.use_gyro = false;
  m.camera_height_m = 1.0;
  m.ground_sigma_m = 0.03;
  m.terrain_planes = terrain;
  // Camera 1 m above the ground looking along body x, 12 deg down (x right, y down, z forward).
  Mat3 R_B_C;
  R_B_C.col(0) = -Vec3::UnitY();
  R_B_C.col(1) = -Vec3::UnitZ();
  R_B_C.col(2) = Vec3::UnitX();
  m.T_B_C.linear() = Eigen::AngleAxisd(12.0 * M_PI / 180.0, Vec3::UnitY()) * R_B_C;
  m.T_B_C.translation() = Vec3(0.0, 0.0, 0.7);
  const Vec3 up_C = m.T_B_C.linear().transpose() * Vec3::UnitZ();
  TrackId next = 100;
  for (int k = 0; k < 2; ++k) {
    auto kf = std::make_unique<Keyframe>(SE3::Identity());
    kf->id = k;
    kf->t_ns = k * 1'000'000'000LL;
    SE3 T = SE3::Identity();
    T.translation() = Vec3(1.0 * k, 0.0, 0.3);  // the body 0.3 m above the ground z = 0
    if (k == 1) out.truth1 = T;
    const SE3 T_C_W = (T * m.T_B_C).inverse();
    for (double x = 1.0; x <= 4.0; x += 0.5) {
      for (double y = -1.0; y <= 1.0; y += 0.5) {
        const Vec3 p_C = T_C_W * Vec3(T.translation().x() + x, y, 0.0);
        Landmark lm;
        lm.id = next++;
        lm.anchor_kf = k;
        lm.bearing_anchor_C = p_C.normalized();
        lm.rho[0] = 1.0 / p_C.norm();
        lm.on_ground = true;
        lm.ground_up_C = up_C;
        out.map.landmarks[lm.id] = lm;
      }
    }
    if (k == 1)
      T.linear() = Eigen::AngleAxisd(1.0 * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix();
    kf->setPose(T);
    out.map.keyframes.push_back(std::move(kf));
  }
  out.gauge.kf_id = 0;
  out.gauge.T_W_B = out.map.keyframes[0]->pose();
  return out;
}

double pitchErrorDegAfterSolve(bool terrain) {
  PitchedSecondKeyframe s = pitchedSecondKeyframe(terrain);
  std::vector<Keyframe*> kfs = {s.map.keyframes[0].get(), s.map.keyframes[1].get()};
  seedTerrain(kfs, s.model);
  SolveOptions so;
  so.max_iterations = 20;
  const SolveSummary summary = solveFactors(buildFactors(kfs, s.map.landmarks, s.model, s.gauge),
                                            kfs, s.map.landmarks, s.model, so);
  EXPECT_TRUE(summary.usable) << summary.message;
  const Mat3 dR = s.truth1.linear().transpose() * kfs[1]->pose().linear();
  return so3::angle(dR) * 180.0 / M_PI;
}

TEST(TerrainPlanes, TheGroundBringsADriftedPitchBack) {
  EXPECT_NEAR(pitchErrorDegAfterSolve(false), 1.0, 1e-6);  // nothing sees it without the terrain
  EXPECT_LT(pitchErrorDegAfterSolve(true), 0.02);
}

TEST(TerrainPlanes, OffOrWithoutACameraHeightTheKeyframesGetNoTerrainFactors) {
  for (const bool terrain : {false, true}) {
    PitchedSecondKeyframe s = pitchedSecondKeyframe(terrain);
    if (terrain) s.model.camera_height_m = 0.0;
    std::vector<Keyframe*> kfs = {s.map.keyframes[0].get(), s.map.keyframes[1].get()};
    seedTerrain(kfs, s.model);
    EXPECT_FALSE(kfs[0]->terrain_set || kfs[1]->terrain_set);
    for (const auto& f : buildFactors(kfs, s.map.landmarks, s.model, s.gauge))
      EXPECT_NE(f.kind, FactorKind::kTerrain);
  }
}

TEST(TerrainPlanes, TheOldestKeyframesPlaneGoesIntoThePriorWithIt) {
  PitchedSecondKeyframe s = pitchedSecondKeyframe(true);
  std::vector<Keyframe*> kfs = {s.map.keyframes[0].get(), s.map.keyframes[1].get()};
  seedTerrain(kfs, s.model);
  EXPECT_EQ(kfs[1]->terrain[2], kfs[0]->terrain[2]);  // seeded from the previous keyframe
  MarginalizationPlan plan;
  for (const auto& [id, lm] : s.map.landmarks)
    if (lm.anchor_kf == 0) plan.marginalized.insert(id);
  const auto info = marginalizeOldest(s.map, s.model, s.gauge, plan, nullptr);
  ASSERT_TRUE(info);
  const auto& kept = info->keptBlocks();
  EXPECT_NE(std::find(kept.begin(), kept.end(), kfs[1]->terrain), kept.end());
  EXPECT_EQ(std::find(kept.begin(), kept.end(), kfs[0]->terrain), kept.end());
}

// A ground-plane association's noise: the beam's range noise seen off the plane (the range sigma
// times the sine of the angle at which the beam meets the ground) and the ground's own roughness,
// in quadrature; the outlier gate measures a landmark's height off the plane against it.
TEST(LidarSigma, AGroundBeamsPlaneIsKnownToItsRangeNoiseTimesTheGrazingSine) {
  WindowModel m = model();
  m.lidar_sigma_m = 0.03;
  m.lidar_range_sigma_m = 0.02;
  m.lidar_ground_sigma_m = 0.004;
  LidarAssociation range;
  range.range_m = 5.0;
  range.planar = true;
  EXPECT_DOUBLE_EQ(lidarSigma(range, m), 0.03);

  const double sin8 = std::sin(8.0 * M_PI / 180.0);
  LidarAssociation ground;
  ground.ground_up_L = Vec3::UnitZ();
  ground.range_m = -0.75;  // the plane z = -0.75 in L
  ground.ground_sin = sin8;
  const double sigma = std::hypot(0.02 * sin8, 0.004);  // 4.9 mm
  EXPECT_NEAR(lidarSigma(ground, m), sigma, 1e-15);

  // Landmarks above the plane, seen from a keyframe at the origin whose LiDAR is its body.
  Keyframe kf(SE3::Identity());
  auto off = [](double dz) { return Vec3(5.0, 0.5, -0.75 + dz); };
  EXPECT_FALSE(lidarOutlier(ground, off(0.9 * 3.0 * sigma), kf, m, 3.0, 0.05));
  EXPECT_TRUE(lidarOutlier(ground, off(1.1 * 3.0 * sigma), kf, m, 3.0, 0.05));
  // A beam meeting the ground head-on knows the plane only to its range noise.
  ground.ground_sin = 1.0;
  EXPECT_NEAR(lidarSigma(ground, m), std::hypot(0.02, 0.004), 1e-15);
  EXPECT_FALSE(lidarOutlier(ground, off(1.1 * 3.0 * sigma), kf, m, 3.0, 0.05));
}

}  // namespace
}  // namespace ovo::estimator
