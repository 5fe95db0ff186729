// A rolling shutter in every consumer of the window: a landmark's point, its LiDAR and terrain
// factors, the outlier test, re-anchoring and the per-frame tracking all place the camera where
// it was when the sighting's row was exposed (Readout::cameraAt), not at the frame's first row.
// Before, only the bearing factors did, and a landmark was two points v * row_s apart: a
// one-signed bias on the LiDAR ranges at driving speed.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "common/so3.hpp"
#include "estimator/window/factors.hpp"
#include "estimator/window/marginalize.hpp"
#include "estimator/window/pose_refinement.hpp"
#include "estimator/window/sighting.hpp"

namespace ovo::estimator {
namespace {

constexpr TrackId kTrack = 3;
constexpr double kReadoutS = 0.025;
constexpr double kRows = 480.0;
constexpr double kRow = 400.0;  // the landmark's row in every image: 20.8 ms after the first

// A forward-looking camera on a body that drives at 0.8 m/s along its x and turns at 0.3 rad/s
// about its z, three keyframes 0.4 m apart, one landmark 5 m ahead and 1 m to the left.
SE3 rigCamera() {
  SE3 T = SE3::Identity();
  T.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // camera z along body x, y down
  T.translation() = Vec3(0.35, 0.0, 0.7);
  return T;
}

WindowModel rollingShutterModel() {
  WindowModel m;
  m.T_B_C = rigCamera();
  m.rolling_shutter_s = kReadoutS;
  m.image_rows = kRows;
  m.use_gyro = false;
  return m;
}

const Vec3 kPointW(5.5, 1.0, 0.6);

struct Scene {
  WindowMap map;
  WindowModel model = rollingShutterModel();
  std::vector<Keyframe*> kfs;
};

Scene drivingScene() {
  Scene s;
  for (int k = 0; k < 3; ++k) {
    auto kf = std::make_unique<Keyframe>(SE3::Identity());
    kf->id = 20 + k;
    kf->t_ns = k * 500'000'000LL;
    SE3 T = SE3::Identity();
    T.linear() = so3::exp(Vec3(0.0, 0.0, 0.05 * k));
    T.translation() = Vec3(0.4 * k, 0.0, 0.0);
    kf->setPose(T);
    kf->readout.rate_B = Vec3(0.0, 0.0, 0.3);
    kf->readout.velocity_B = Vec3(0.8, 0.0, 0.0);
    kf->T_B_L.translation() = Vec3(0.45, 0.0, 0.45);
    TrackObservation o;
    o.track_id = kTrack;
    o.px = Vec2(300.0, kRow);
    o.row_s = s.model.rowTime(o.px);
    // The sighting as the camera saw it at its row's time.
    o.bearing_C = ((T * kf->cameraAt(o, s.model.T_B_C)).inverse() * kPointW).normalized();
    o.age = 1 + 10 * k;
    kf->observations[kTrack] = o;
    s.kfs.push_back(kf.get());
    s.map.keyframes.push_back(std::move(kf));
  }
  const Keyframe& anchor = *s.map.keyframes.front();
  const TrackObservation& oa = anchor.observations.at(kTrack);
  Landmark lm;
  lm.id = kTrack;
  lm.anchor_kf = anchor.id;
  lm.bearing_anchor_C = oa.bearing_C;
  lm.anchor_row_s = oa.row_s;
  lm.rho[0] = 1.0 / ((anchor.pose() * anchor.cameraAt(oa, s.model.T_B_C)).inverse() * kPointW).norm();
  s.map.landmarks[kTrack] = lm;
  return s;
}

TEST(RollingShutter, TheRowTimeIsTheRowsShareOfTheReadout) {
  const WindowModel m = rollingShutterModel();
  EXPECT_DOUBLE_EQ(m.rowTime(Vec2(10.0, 0.0)), 0.0);
  EXPECT_DOUBLE_EQ(m.rowTime(Vec2(10.0, 240.0)), 0.5 * kReadoutS);
  EXPECT_DOUBLE_EQ(m.rowTime(Vec2(10.0, 2000.0)), kReadoutS);  // clamped to the image
  WindowModel global = m;
  global.rolling_shutter_s = 0.0;
  EXPECT_EQ(global.rowTime(Vec2(10.0, 400.0)), 0.0);
}

TEST(RollingShutter, ALandmarksPointIsWhereItsAnchorCameraWasAtItsRow) {
  const Scene s = drivingScene();
  const auto p = s.map.pointW(kTrack, s.model.T_B_C);
  ASSERT_TRUE(p);
  // At the frame's first row the camera was 17 mm behind: that point would be 17 mm off.
  EXPECT_LT((*p - kPointW).norm(), 1e-9);
}

TEST(RollingShutter, TheLidarRangeOfALandmarkHasNoResidualAtTheTrueStates) {
  Scene s = drivingScene();
  for (Keyframe* kf : s.kfs) {
    LidarAssociation a;
    a.track_id = kTrack;
    a.range_m = ((kf->pose() * kf->T_B_L).inverse() * kPointW).norm();
    kf->lidar.push_back(a);
  }
  s.model.lidar_sigma_m = 0.001;  // 1 mm: an offset of the camera's readout shows as sigmas
  int checked = 0;
  for (const auto& f : buildFactors(s.kfs, s.map.landmarks, s.model, {})) {
    if (f.kind != FactorKind::kLidar) continue;
    double r = 1.0;
    ASSERT_TRUE(f.cost->Evaluate(f.blocks.data(), &r, nullptr));
    EXPECT_NEAR(r, 0.0, 1e-6) << "keyframe " << f.kf_id;
    ++checked;
  }
  EXPECT_EQ(checked, 3);  // the anchor's own range and the two others
}

TEST(RollingShutter, TheTerrainFactorPlacesTheLandmarkFromItsRowsCamera) {
  Scene s = drivingScene();
  s.model.camera_height_m = 1.0;  // terrain planes need a camera height
  s.model.terrain_planes = true;
  s.model.ground_sigma_m = 0.001;
  Landmark& lm = s.map.landmarks.at(kTrack);
  lm.on_ground = true;
  Keyframe& anchor = *s.kfs.front();
  // A slope across the drive, z = 0.3 x + c through the true point: the readout's motion is
  // horizontal here, so only a sloped plane sees where the point is.
  anchor.terrain[0] = 0.3;
  anchor.terrain[1] = 0.0;
  anchor.terrain[2] = kPointW.z() - 0.3 * kPointW.x();
  anchor.terrain_set = true;
  int checked = 0;
  for (const auto& f : buildFactors(s.kfs, s.map.landmarks, s.model, {})) {
    if (f.kind != FactorKind::kTerrain || f.track != kTrack) continue;
    double r = 1.0;
    ASSERT_TRUE(f.cost->Evaluate(f.blocks.data(), &r, nullptr));
    EXPECT_NEAR(r, 0.0, 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, 1);
}

TEST(RollingShutter, TheOutlierTestSeesNoErrorAtTheTrueStates) {
  const Scene s = drivingScene();
  const auto errors = observationErrors(s.kfs, s.map.landmarks, s.model);
  ASSERT_EQ(errors.size(), 2u);
  for (const auto& e : errors) EXPECT_LT(e.angle_rad, 1e-9) << "keyframe " << e.kf_id;
}

TEST(RollingShutter, ReanchoringKeepsTheLandmarksPoint) {
  Scene s = drivingScene();
  WindowOptions options;
  const MarginalizationPlan plan = planMarginalization(s.map, s.model.T_B_C, options);
  ASSERT_TRUE(plan.reanchor.count(kTrack));
  reanchorLandmarks(s.map, 20, plan);
  s.map.keyframes.pop_front();
  const auto p = s.map.pointW(kTrack, s.model.T_B_C);
  ASSERT_TRUE(p);
  EXPECT_EQ(s.map.landmarks.at(kTrack).anchor_kf, 21);
  EXPECT_LT((*p - kPointW).norm(), 1e-9);
}

// A frame tracked against fixed points, each seen at its own row while the body moves: with each
// sighting's camera at its row the true pose comes back; with the first row's camera for all it
// does not.
TEST(RollingShutter, AFrameTrackedAgainstTheMapIsPlacedFromItsRowsCameras) {
  const WindowModel m = rollingShutterModel();
  SE3 T_W_B = SE3::Identity();
  T_W_B.linear() = so3::exp(Vec3(0.0, 0.0, 0.1));
  T_W_B.translation() = Vec3(1.0, 0.2, 0.0);
  Readout readout;
  readout.rate_B = Vec3(0.0, 0.0, 0.4);
  readout.velocity_B = Vec3(0.8, 0.0, 0.0);
  std::vector<Vec3> points_W, bearings_C;
  std::vector<SE3> cameras_B;
  for (int i = 0; i < 30; ++i) {
    const double row = 16.0 * i;
    const Vec3 p_W(6.0 + 0.3 * (i % 5), -2.0 + 0.15 * i, -0.5 + 0.1 * (i % 7));
    const SE3 T_B_C = readout.cameraAt(m.rowTime(Vec2(320.0, row)), m.T_B_C);
    points_W.push_back(p_W);
    bearings_C.push_back(((T_W_B * T_B_C).inverse() * p_W).normalized());
    cameras_B.push_back(T_B_C);
  }
  SE3 start = T_W_B;
  start.translation() += Vec3(0.05, -0.03, 0.02);
  const auto rows = refinePose(points_W, bearings_C, cameras_B, start, std::nullopt, 1.0, m, 50,
                               0.1);
  ASSERT_TRUE(rows);
  EXPECT_EQ(rows->num_inliers, 30);
  EXPECT_LT((rows->T_W_B.translation() - T_W_B.translation()).norm(), 1e-6);
  const auto first_row = refinePose(points_W, bearings_C, {}, start, std::nullopt, 1.0, m, 50, 0.1);
  ASSERT_TRUE(first_row);
  EXPECT_GT((first_row->T_W_B.translation() - T_W_B.translation()).norm(), 1e-3);
}

}  // namespace
}  // namespace ovo::estimator
