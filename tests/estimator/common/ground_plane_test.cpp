#include "estimator/common/ground_plane.hpp"

#include <gtest/gtest.h>

#include <random>

namespace ovo::estimator {
namespace {

// A road plane 1.65 m below a camera pitched down by `pitch`, plus off-plane clutter.
std::vector<Vec3> scene(double pitch_rad, double scale, int n_ground, int n_clutter,
                        std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-6, 6), uz(3, 30), noise(-0.01, 0.01);
  // Level frame: y down; camera rotated about x by pitch (positive = looking down).
  const Mat3 R_C_level = Eigen::AngleAxisd(-pitch_rad, Vec3::UnitX()).toRotationMatrix();
  std::vector<Vec3> pts;
  for (int i = 0; i < n_ground; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double z = uz(rng), y = 1.65 + noise(rng), x = ux(rng);
    pts.push_back(scale * (R_C_level * Vec3(x, y, z)));
  }
  for (int i = 0; i < n_clutter; ++i) {
    std::uniform_real_distribution<double> uy(-3, 1.2);
    const double z = uz(rng), y = uy(rng), x = ux(rng);
    pts.push_back(scale * (R_C_level * Vec3(x, y, z)));
  }
  return pts;
}

TEST(GroundPlane, RecoversHeightAndPitchAtUnknownScale) {
  const double pitch = 3.0 * M_PI / 180.0, scale = 0.37;
  const auto pts = scene(pitch, scale, 150, 100, 1);
  const auto g = fitGroundPlane(pts, Vec3(0, -1, 0), GroundPlaneOptions{});
  ASSERT_TRUE(g.has_value());
  EXPECT_NEAR(g->height / scale, 1.65, 0.01);
  // The up normal in C of a camera pitched down: level up (0,-1,0) seen from the tilted camera.
  const Vec3 expected =
      Eigen::AngleAxisd(-pitch, Vec3::UnitX()).toRotationMatrix() * Vec3(0, -1, 0);
  EXPECT_LT(std::acos(std::min(1.0, g->up_C.dot(expected))) * 180.0 / M_PI, 0.3);
}

TEST(GroundPlane, RejectsWhenNoGroundIsSeen) {
  std::vector<Vec3> wall;
  for (int i = 0; i < 100; ++i) wall.push_back(Vec3(-2.0 + 0.04 * i, -1.0 + 0.01 * (i % 20), 10.0));
  EXPECT_FALSE(fitGroundPlane(wall, Vec3(0, -1, 0), GroundPlaneOptions{}).has_value());
  EXPECT_FALSE(fitGroundPlane({}, Vec3(0, -1, 0), GroundPlaneOptions{}).has_value());
}

}  // namespace
}  // namespace ovo::estimator
