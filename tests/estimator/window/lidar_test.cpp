// LiDAR geometry of the window's range association: a LiDAR pitched down 8 degrees, 0.75 m above
// flat ground, meets it grazing about 5.4 m ahead. A landmark on the ground a fraction of a degree
// off the scan plane is far from the beam's range there; the ground plane through the beam end
// gives its true scan-plane distance. Known answers from the world geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "estimator/common/lidar_scale.hpp"
#include "estimator/window/lidar_association.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kLidarHeight = 0.75;

// World: z up, ground z = 0. LiDAR at (0, 0, 0.75), its x axis pitched 8 degrees down.
Mat3 R_W_L() { return Eigen::AngleAxisd(8.0 * kDeg, Vec3::UnitY()).toRotationMatrix(); }
const Vec3 kLidarW(0.0, 0.0, kLidarHeight);

Vec3 toL(const Vec3& p_W) { return R_W_L().transpose() * (p_W - kLidarW); }

// Where the beam at azimuth phi meets the ground, in L.
Vec3 groundHitL(double phi) {
  const Vec3 d_L(std::cos(phi), std::sin(phi), 0.0);
  const Vec3 up_L = R_W_L().transpose() * Vec3::UnitZ();
  const Vec3 ground_L = toL(Vec3::Zero());
  return d_L * (up_L.dot(ground_L) / up_L.dot(d_L));
}

TEST(GroundRangeAlongRay, GivesTheScanPlaneDistanceOfAGroundPointOffThePlane) {
  const Vec3 up_L = R_W_L().transpose() * Vec3::UnitZ();
  const Vec3 camera_W(-0.1, 0.05, 1.0);
  const Vec3 c_L = toL(camera_W);
  // Ground points near the scan line ahead and to the side, up to ~0.7 degrees off the plane.
  for (const Vec3& q_W : {Vec3(5.0, 0.3, 0.0), Vec3(5.9, -0.8, 0.0), Vec3(4.4, 1.6, 0.0)}) {
    const Vec3 q_L = toL(q_W);
    const double phi = std::atan2(q_L.y(), q_L.x());
    const Vec3 hit_L = groundHitL(phi);
    ASSERT_NEAR(hit_L.z(), 0.0, 1e-12);
    const auto d = groundRangeAlongRay(hit_L, up_L, c_L, toL(q_W) - c_L);
    ASSERT_TRUE(d.has_value());
    EXPECT_NEAR(*d, q_L.head<2>().norm(), 1e-9);
    // The beam's own range is tens of centimetres off: why the plane is needed.
    EXPECT_GT(std::abs(hit_L.norm() - q_L.head<2>().norm()), 0.1) << q_W.transpose();
  }
}

TEST(GroundRangeAlongRay, ARayThatDoesNotGoDownToTheGroundGivesNothing) {
  const Vec3 up_L = R_W_L().transpose() * Vec3::UnitZ();
  const Vec3 c_L = toL(Vec3(-0.1, 0.0, 1.0));
  const Vec3 hit_L = groundHitL(0.0);
  const Vec3 level_W(1.0, 0.0, 0.0), up_W(1.0, 0.0, 0.3);
  EXPECT_FALSE(groundRangeAlongRay(hit_L, up_L, c_L, R_W_L().transpose() * level_W));
  EXPECT_FALSE(groundRangeAlongRay(hit_L, up_L, c_L, R_W_L().transpose() * up_W));
}

TEST(GroundIncidenceSine, IsThePitchTimesTheAzimuthsCosineForAPitchedLidarOverFlatGround) {
  // A beam at azimuth phi of a LiDAR pitched 8 degrees down points sin(8 deg) cos(phi) down.
  const Vec3 up_L = R_W_L().transpose() * Vec3::UnitZ();
  for (const double phi_deg : {0.0, 25.0, -50.0}) {
    const double phi = phi_deg * kDeg;
    EXPECT_NEAR(groundIncidenceSine(groundHitL(phi), up_L), std::sin(8.0 * kDeg) * std::cos(phi),
                1e-12)
        << phi_deg;
    // A range error dr along that beam moves its end that much times the sine off the ground.
    const Vec3 hit_L = groundHitL(phi), longer_L = hit_L * (1.0 + 0.05 / hit_L.norm());
    EXPECT_NEAR(std::abs(up_L.dot(longer_L - hit_L)),
                0.05 * groundIncidenceSine(groundHitL(phi), up_L), 1e-12);
  }
  EXPECT_EQ(groundIncidenceSine(Vec3::Zero(), up_L), 0.0);
}

TEST(IsGroundBeam, TellsGroundHitsFromTheCanopyByTheirDepthBelowTheCamera) {
  const double height = 1.0;                                        // camera above the ground
  const Vec3 up_C(0.0, -1.0, 0.0);                                  // camera y points down
  EXPECT_TRUE(isGroundBeam(Vec3(0.1, 0.98, 5.0), up_C, height));    // on the ground ahead
  EXPECT_FALSE(isGroundBeam(Vec3(1.5, 0.25, 1.0), up_C, height));   // canopy beside, lower
  EXPECT_FALSE(isGroundBeam(Vec3(-1.5, -0.2, 2.0), up_C, height));  // canopy above
  EXPECT_FALSE(isGroundBeam(Vec3(0.1, 0.98, 5.0), up_C, 0.0));      // no camera height: none
}

TEST(InterpolateRange, IsLinearBetweenBeamsAndRefusesADepthEdge) {
  LidarScan scan;
  scan.angle_min_rad = -0.5;
  scan.angle_increment_rad = 0.01;
  scan.ranges_m.resize(101);
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) scan.ranges_m[i] = 2.0 + 0.001 * i;
  scan.range_min_m = 0.1;
  scan.range_max_m = 30.0;
  // Between beams 40 (2.040 m) and 41 (2.041 m), a quarter of the way.
  const auto r = interpolateRange(scan, -0.5 + 0.4025, 0.05, 2);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(*r, 2.04025, 1e-9);
  scan.ranges_m[60] = 3.0;  // an edge (a canopy gap) two beams away
  EXPECT_FALSE(interpolateRange(scan, -0.5 + 0.585, 0.05, 2).has_value());
  EXPECT_TRUE(interpolateRange(scan, -0.5 + 0.585, 0.05, 0).has_value());  // no edge test
}

// A 270-degree scanner's scan (-135..135 deg, 0.5 deg) with a smooth wall and one depth edge, as
// it was published and republished two ways: as 0..2 pi (720 beams, the gap behind it empty) and
// with a negative increment (from +135 down to -135 deg). Every azimuth reads the same range (or
// none) from all three.
TEST(InterpolateRange, AScanRepublishedAs0To2PiOrWithANegativeIncrementReadsTheSame) {
  constexpr double kDeg = M_PI / 180.0;
  LidarScan original;
  original.angle_min_rad = -135.0 * kDeg;
  original.angle_increment_rad = 0.5 * kDeg;
  original.range_min_m = 0.1;
  original.range_max_m = 30.0;
  for (int i = 0; i <= 540; ++i) {
    const double a = original.angle(static_cast<std::size_t>(i));
    original.ranges_m.push_back(i == 300 ? 9.0 : 3.0 + std::sin(a));  // beam 300: an edge
  }
  LidarScan circle = original;
  circle.angle_min_rad = 0.0;
  circle.ranges_m.assign(720, std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i <= 540; ++i)  // beam i at -135 + 0.5 i deg sits at (450 + i) mod 720
    circle.ranges_m[static_cast<std::size_t>((450 + i) % 720)] = original.ranges_m[i];
  LidarScan reversed = original;
  reversed.angle_min_rad = 135.0 * kDeg;
  reversed.angle_increment_rad = -0.5 * kDeg;
  std::reverse(reversed.ranges_m.begin(), reversed.ranges_m.end());
  int read = 0;
  for (double deg = -179.9; deg < 180.0; deg += 0.37) {
    const double phi = deg * kDeg;
    const auto r = interpolateRange(original, phi, 0.05, 2);
    for (const LidarScan* other : {&circle, &reversed}) {
      const auto o = interpolateRange(*other, phi, 0.05, 2);
      ASSERT_EQ(r.has_value(), o.has_value()) << deg << " deg";
      if (r) {
        EXPECT_NEAR(*r, *o, 1e-9) << deg << " deg";
      }
    }
    read += r.has_value();
  }
  EXPECT_GT(read, 680);  // all of the 270 degrees but the edge's neighbourhood
}

// A 360-degree scan reads across its seam (between its last beam and its first).
TEST(InterpolateRange, AFullCircleReadsAcrossItsSeam) {
  LidarScan scan;
  scan.angle_min_rad = -M_PI;
  scan.angle_increment_rad = 2.0 * M_PI / 720.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = 30.0;
  scan.ranges_m.assign(720, 4.0);
  scan.ranges_m.back() = 4.1;
  const double phi = M_PI - 0.25 * scan.angle_increment_rad;  // three quarters past the last beam
  const auto r = interpolateRange(scan, phi, 0.05, 2);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(*r, 0.25 * 4.1 + 0.75 * 4.0, 1e-9);
  EXPECT_TRUE(interpolateRange(scan, -M_PI + 1e-4, 0.05, 2).has_value());  // by the first beam
}

}  // namespace
}  // namespace ovo::estimator
