// marginalizeOldest's choice of factors: a landmark that ends with the oldest keyframe puts all of
// its observations into the prior; one that the window re-anchors puts in only the link to its new
// anchor, so that its later observations, which stay in the window, are not counted twice.
#include "estimator/window_problem.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/so3.hpp"

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

TEST(MarginalizeOldest, AnEndingLandmarkPutsAllItsObservationsIntoThePrior) {
  WindowMap map = threeKeyframesOneLandmark();
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), {{kTrack, -1}});
  ASSERT_TRUE(info);
  EXPECT_TRUE(keeps(*info, *map.keyframes[1]));
  EXPECT_TRUE(keeps(*info, *map.keyframes[2]));
}

TEST(MarginalizeOldest, AReanchoredLandmarkPutsInOnlyTheLinkToItsNewAnchor) {
  WindowMap map = threeKeyframesOneLandmark();
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), {{kTrack, 11}});
  ASSERT_TRUE(info);
  EXPECT_TRUE(keeps(*info, *map.keyframes[1]));
  // The observation in keyframe 12 stays a factor of the re-anchored landmark, not in the prior.
  EXPECT_FALSE(keeps(*info, *map.keyframes[2]));
}

TEST(MarginalizeOldest, ALandmarkNotSelectedIsDropped) {
  WindowMap map = threeKeyframesOneLandmark();
  // Only the gauge's prior on the oldest pose is left: nothing about the other keyframes.
  const auto info = marginalizeOldest(map, model(), gaugeOnTheOldest(), {});
  EXPECT_TRUE(!info || (!keeps(*info, *map.keyframes[1]) && !keeps(*info, *map.keyframes[2])));
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
  std::unordered_map<TrackId, int> ending;
  for (const auto& [id, lm] : s.map.landmarks)
    if (lm.anchor_kf == 0) ending[id] = -1;
  const auto info = marginalizeOldest(s.map, s.model, s.gauge, ending);
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
