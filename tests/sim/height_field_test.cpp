// Uneven ground: the height field, its normals, rays hitting it and the body riding on it.
#include "sim/height_field.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "common/so3.hpp"
#include "sim/imu.hpp"
#include "sim/lidar.hpp"
#include "sim/simulation.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

const Rect2 kPlateau{-10.0, 50.0, -10.0, 20.0};

TEST(HeightField, ItsSinCosAgreesWithTheLibrarysToAFewUlp) {
  // Phases as the waves have them over a vineyard and beyond, both signs, every quadrant.
  double worst = 0.0;
  for (double x = -3000.0; x <= 3000.0; x += 0.0123457) {
    double s = 0.0, c = 0.0;
    sinCos(x, &s, &c);
    worst = std::max({worst, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
  }
  EXPECT_LT(worst, 4e-16);
  double s = 1.0, c = 0.0;
  sinCos(0.0, &s, &c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
}

TEST(HeightField, DerivativesMatchFiniteDifferences) {
  const HeightField field(0.03, 1.5, 7, kPlateau);
  const double h = 1e-4;
  for (const Vec2& p : {Vec2(1.3, 2.7), Vec2(17.1, -4.2), Vec2(33.3, 12.9)}) {
    const Vec2 u(0.7, -0.4);
    const HeightSample s = field.sample(p.x(), p.y(), u);
    EXPECT_NEAR(s.h, field.height(p.x(), p.y()), 1e-15);
    const auto at = [&](const Vec2& q) { return field.sample(q.x(), q.y(), u); };
    for (int i = 0; i < 2; ++i) {
      const Vec2 e = h * Vec2::Unit(i);
      const HeightSample a = at(p - e), b = at(p + e);
      EXPECT_NEAR(s.grad[i], (b.h - a.h) / (2 * h), 1e-8);
      EXPECT_LT((s.hess.col(i) - (b.grad - a.grad) / (2 * h)).norm(), 1e-6);
    }
    // Third derivatives along u: d/ds (H(p + s u) u) at s = 0.
    const HeightSample a = at(p - h * u), b = at(p + h * u);
    EXPECT_LT((s.third_uu - (b.hess * u - a.hess * u) / (2 * h)).norm(), 1e-5);
    Vec2 g;
    field.height(p.x(), p.y(), &g);
    EXPECT_LT((g - s.grad).norm(), 1e-15);  // on the plateau the window is 1
  }
}

TEST(HeightField, HasTheRoughnessAsStdStaysWithinItsBoundAndFadesOutsideTheField) {
  const double sigma = 0.04;
  const HeightField field(sigma, 2.0, 3, kPlateau);
  double sum = 0.0, sum2 = 0.0, max_abs = 0.0;
  int n = 0;
  for (double x = -10.0; x <= 50.0; x += 0.37)
    for (double y = -10.0; y <= 20.0; y += 0.41) {
      const double v = field.height(x, y);
      sum += v;
      sum2 += v * v;
      max_abs = std::max(max_abs, std::abs(v));
      ++n;
    }
  const double mean = sum / n, std = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.3 * sigma);
  EXPECT_NEAR(std, sigma, 0.3 * sigma);  // one seed's field: its sample std scatters
  EXPECT_LE(max_abs, field.bound());
  EXPECT_GT(max_abs, 2.0 * sigma);
  EXPECT_GT(field.minWavelength(), 2.0 / 1.7);
  // Zero beyond the fade, in between less than on the plateau.
  EXPECT_EQ(field.height(kPlateau.x1 + 10.5, 5.0), 0.0);
  EXPECT_EQ(field.height(5.0, kPlateau.y0 - 10.5), 0.0);
}

TEST(HeightField, WorldGroundIsThePlanePlusTheFieldWithItsNormal) {
  WorldOptions w;
  w.grade_pct = 8.0;
  w.side_tilt_pct = 3.0;
  w.ground_roughness_m = 0.03;
  w.ground_wavelength_m = 1.5;
  const VineyardWorld world(w, 4);
  ASSERT_TRUE(world.heightField());
  const double h = 1e-5;
  for (const Vec2& p : {Vec2(3.0, 4.0), Vec2(25.0, 7.5), Vec2(42.0, -2.0)}) {
    const double z = world.groundHeight(p.x(), p.y());
    EXPECT_NEAR(z, 0.08 * p.x() + 0.03 * p.y() + world.heightField()->height(p.x(), p.y()), 1e-12);
    const double dzdx =
        (world.groundHeight(p.x() + h, p.y()) - world.groundHeight(p.x() - h, p.y())) / (2 * h);
    const double dzdy =
        (world.groundHeight(p.x(), p.y() + h) - world.groundHeight(p.x(), p.y() - h)) / (2 * h);
    const Vec3 n = Vec3(-dzdx, -dzdy, 1.0).normalized();
    EXPECT_LT((world.groundNormalAt(p.x(), p.y()) - n).norm(), 1e-8);
  }
  // Without roughness the ground is the plane, exactly.
  WorldOptions flat = w;
  flat.ground_roughness_m = 0.0;
  const VineyardWorld plane(flat, 4);
  EXPECT_FALSE(plane.heightField());
  EXPECT_EQ(plane.groundHeight(3.0, 4.0), 0.08 * 3.0 + 0.03 * 4.0);
}

TEST(HeightField, RaysHitTheUnevenGroundOnItsSurfaceAndNotBefore) {
  WorldOptions w;
  w.num_rows = 0;
  w.backdrop = false;
  w.grade_pct = 10.0;
  w.ground_roughness_m = 0.04;
  w.ground_wavelength_m = 1.2;
  const VineyardWorld world(w, 9);
  int hits = 0;
  for (double azimuth = 0.0; azimuth < 2.0 * M_PI; azimuth += 0.5) {
    for (double down_deg : {60.0, 20.0, 6.0, 2.0}) {
      const double dn = down_deg * M_PI / 180.0;
      const Vec3 o(10.0, 5.0, world.groundHeight(10.0, 5.0) + 0.5);
      const Vec3 d(std::cos(dn) * std::cos(azimuth), std::cos(dn) * std::sin(azimuth),
                   -std::sin(dn));
      const auto r = world.firstOpaqueHit(o, d, 40.0, 0.0);
      if (!r) continue;  // the grazing rays uphill may run past 40 m
      const Vec3 p = o + *r * d;
      EXPECT_NEAR(p.z(), world.groundHeight(p.x(), p.y()), 1e-6) << azimuth << " " << down_deg;
      for (double s = 0.0; s < *r - 1e-3; s += 0.01) {  // above the ground all the way
        const Vec3 q = o + s * d;
        ASSERT_GT(q.z(), world.groundHeight(q.x(), q.y()) - 1e-9) << azimuth << " " << down_deg;
      }
      ++hits;
    }
  }
  EXPECT_GT(hits, 40);
}

TEST(HeightField, PostsStandOnTheUnevenGround) {
  // A beam aimed 2 cm above the uneven ground at the row-end post's base meets the post there.
  WorldOptions w;
  w.num_rows = 1;
  w.leaf_density = 0.0;
  w.wire_radius_m = 0.0;
  w.backdrop = false;
  w.ground_roughness_m = 0.03;
  w.ground_wavelength_m = 1.5;
  const VineyardWorld world(w, 2);
  const double r_post = 1.6 * w.post_radius_m;
  const double zb = world.groundHeight(0.0, 0.0);
  const Vec3 target(-r_post, 0.0, zb + 0.02);
  const Vec3 o(-1.0, 0.0, zb + 0.6);
  const Vec3 d = (target - o).normalized();
  const auto r = world.firstOpaqueHit(o, d, 10.0, 0.0);
  ASSERT_TRUE(r);
  EXPECT_NEAR(*r, (target - o).norm(), 1e-3);
}

Scenario roughScenario() {
  Scenario s = test::exactScenario();
  s.world.grade_pct = 8.0;
  s.world.side_tilt_pct = 3.0;
  s.world.ground_roughness_m = 0.03;
  s.world.ground_wavelength_m = 1.5;
  s.trajectory.vibration_sigma_deg = 0.0;
  s.trajectory.bump_sigma_m = 0.0;
  return s;
}

TEST(HeightField, BodyRidesOnTheLocalGroundWithItsNormalAsUp) {
  const Scenario s = roughScenario();
  const VineyardWorld world(s.world, s.seed);
  const BodyTrajectory traj = planTrajectory(s.trajectory, world, s.seed);
  double max_tilt = 0.0;
  for (double t = 0.3; t < traj.duration(); t += 0.77) {
    const SE3 T = traj.T_W_B(t);
    Vec3 ground, normal;
    traj.groundContact(t, &ground, &normal);
    EXPECT_NEAR(ground.z(), world.groundHeight(ground.x(), ground.y()), 1e-12);
    EXPECT_LT((normal - world.groundNormalAt(ground.x(), ground.y())).norm(), 1e-12);
    // Up is the local normal (roll and pitch from it), the origin body_height above the ground.
    EXPECT_LT((T.linear().col(2) - normal).norm(), 1e-12) << t;
    EXPECT_LT((T.translation() - (ground + s.trajectory.body_height_m * normal)).norm(), 1e-12);
    EXPECT_NEAR(T.linear().col(0).dot(normal), 0.0, 1e-12);  // x along the local ground
    max_tilt = std::max(max_tilt, std::acos(normal.dot(world.groundNormal())));
  }
  EXPECT_GT(max_tilt, 1.0 * M_PI / 180.0);  // the bumps tilt the body by degrees
}

TEST(HeightField, BodyDerivativesOnUnevenGroundMatchFiniteDifferences) {
  Scenario s = roughScenario();
  s.trajectory.vibration_sigma_deg = 0.3;  // vibration and bumps on top of the ground
  s.trajectory.bump_sigma_m = 0.004;
  const VineyardWorld world(s.world, s.seed);
  const BodyTrajectory traj = planTrajectory(s.trajectory, world, s.seed);
  const double h = 1e-4;
  for (double t = 0.713; t < traj.duration(); t += 2.9) {  // off the knots
    const BodyState x = traj.state(t);
    const BodyState a = traj.state(t - h), b = traj.state(t + h);
    EXPECT_LT((x.v_W - (b.T_W_B.translation() - a.T_W_B.translation()) / (2 * h)).norm(), 1e-5)
        << t;
    EXPECT_LT((x.a_W - (b.v_W - a.v_W) / (2 * h)).norm(), 2e-4) << t;
    const Vec3 omega_fd = so3::log(a.T_W_B.linear().transpose() * b.T_W_B.linear()) / (2 * h);
    EXPECT_LT((x.omega_B - omega_fd).norm(), 1e-5) << t;
  }
}

TEST(HeightField, GyroIntegratesToTheTruthsRotationOnUnevenGround) {
  // Noise-free gyro at 200 Hz, integrated over the whole run (midpoint rule on consecutive
  // samples): the rotation matches the ground truth's, bumps' roll and pitch included.
  Scenario s = roughScenario();
  s.world.ground_roughness_m = 0.04;
  s.frames = 0;
  const Simulation sim(s);
  const std::vector<ImuSample> imu = sim.imu();
  Mat3 R = sim.trajectory().T_W_B(0.0).linear();
  double max_err = 0.0, max_rate = 0.0;
  for (std::size_t k = 1; k < imu.size(); ++k) {
    const double dt = toSeconds(imu[k].t_ns - imu[k - 1].t_ns);
    R = R * so3::exp(0.5 * (imu[k - 1].gyro_radps + imu[k].gyro_radps) * dt);
    const double t = toSeconds(imu[k].t_ns - s.start_time_ns);
    const Mat3 R_true = sim.trajectory().T_W_B(t).linear();
    max_err = std::max(max_err, so3::log(R_true.transpose() * R).norm());
    const Vec3 w = imu[k].gyro_radps;
    max_rate = std::max(max_rate, std::hypot(w.x(), w.y()));
  }
  EXPECT_LT(max_err, 2e-3);                 // rad, over about 40 s
  EXPECT_GT(max_rate, 3.0 * M_PI / 180.0);  // the ground rolls and pitches the body
}

TEST(HeightField, CameraHeightIsAboveTheLocalGround) {
  Scenario s = roughScenario();
  s.frames = 1;
  const Simulation sim(s);
  // The camera mount is 0.7 m above a body 0.3 m above the ground.
  EXPECT_NEAR(sim.cameraHeightM(), 1.0, 1e-9);
}

}  // namespace
}  // namespace ovo::sim
