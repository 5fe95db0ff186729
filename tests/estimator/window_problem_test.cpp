// marginalizeOldest's choice of factors: a landmark that ends with the oldest keyframe puts all of
// its observations into the prior; one that the window re-anchors puts in only the link to its new
// anchor, so that its later observations, which stay in the window, are not counted twice.
#include "estimator/window_problem.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

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

}  // namespace
}  // namespace ovo::estimator
