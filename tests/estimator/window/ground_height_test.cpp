// agreedGroundHeight over labelGroundLandmarks' planes: the camera's height over the ground in the
// units of a window started without a scale (WindowCore::rescaleToGround takes the window to the
// rig's height with it).
#include <gtest/gtest.h>

#include <random>

#include "estimator/window/refine.hpp"

namespace ovo::estimator {
namespace {

// Camera z forward, x right, y down on a body with x forward, z up.
WindowModel levelCameraModel() {
  WindowModel model;
  Mat3 R_B_C;
  R_B_C << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  model.T_B_C.linear() = R_B_C;
  model.camera_height_m = 1.65;
  return model;
}

// Landmarks anchored in keyframe `kf`: ground points 1.65 m below the camera and clutter above
// it, all in units where 1 m is `scale`.
void addAnchor(std::unordered_map<TrackId, Landmark>& lms, int kf, double scale,
               std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-6, 6), uz(3, 25), noise(-0.01, 0.01), uy(-3, 1.0);
  for (int i = 0; i < 160; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double z = uz(rng), y = i < 100 ? 1.65 + noise(rng) : uy(rng), x = ux(rng);
    const Vec3 p = scale * Vec3(x, y, z);
    Landmark lm;
    lm.id = static_cast<TrackId>(lms.size() + 1);
    lm.anchor_kf = kf;
    lm.bearing_anchor_C = p.normalized();
    lm.rho[0] = 1.0 / p.norm();
    lms[lm.id] = lm;
  }
}

std::optional<double> windowGroundHeight(std::unordered_map<TrackId, Landmark>& lms) {
  return agreedGroundHeight(
      labelGroundLandmarks(lms, levelCameraModel(), WindowOptions{}, GroundPlaneOptions{}), 2, 0.1);
}

TEST(WindowGroundHeight, TheKeyframesPlanesGiveTheHeightInTheWindowsUnits) {
  std::unordered_map<TrackId, Landmark> lms;
  for (int kf = 0; kf < 3; ++kf) addAnchor(lms, kf, 0.3, 11 + kf);
  const auto h = windowGroundHeight(lms);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(*h, 0.3 * 1.65, 0.01);
}

TEST(WindowGroundHeight, OneKeyframesPlaneOrDisagreeingPlanesGiveNone) {
  std::unordered_map<TrackId, Landmark> one;
  addAnchor(one, 0, 0.3, 11);
  EXPECT_FALSE(windowGroundHeight(one));
  std::unordered_map<TrackId, Landmark> apart;  // three keyframes, three scales
  addAnchor(apart, 0, 0.3, 11);
  addAnchor(apart, 1, 0.6, 12);
  addAnchor(apart, 2, 0.9, 13);
  EXPECT_FALSE(windowGroundHeight(apart));
  // Two of four are not a majority; two of three are.
  addAnchor(apart, 3, 0.62, 14);
  EXPECT_FALSE(windowGroundHeight(apart));
  std::unordered_map<TrackId, Landmark> two_of_three;
  addAnchor(two_of_three, 0, 0.3, 11);
  addAnchor(two_of_three, 1, 0.6, 12);
  addAnchor(two_of_three, 2, 0.62, 14);
  const auto h = windowGroundHeight(two_of_three);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(*h, 0.6 * 1.65, 0.05);
}

}  // namespace
}  // namespace ovo::estimator
