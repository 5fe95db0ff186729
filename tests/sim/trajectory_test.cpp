#include "sim/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "common/config.hpp"
#include "common/so3.hpp"
#include "sim/scenario.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

struct Planned {
  Scenario scenario;
  VineyardWorld world;
  BodyTrajectory trajectory;
  explicit Planned(const Scenario& s)
      : scenario(s),
        world(s.world, s.seed),
        trajectory(planTrajectory(s.trajectory, world, s.seed)) {}
};

Scenario fromFile(const std::string& name) {
  return readScenario(Config::load(::ovo::test::sourcePath("configs/sim/" + name + ".yaml")));
}

double yawOf(const SE3& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

TEST(Trajectory, AccelerationAndAngularAccelerationAreContinuousAtKnots) {
  Scenario s = test::defaultScenario();
  s.world.grade_pct = 20.0;
  const Planned p(s);
  const double knot = s.trajectory.vibration_knot_s;
  const double eps = 1e-7;
  double max_jump_a = 0.0, max_jump_alpha = 0.0;
  for (double t = knot; t < p.trajectory.duration() - knot; t += knot) {
    const BodyState lo = p.trajectory.state(t - eps), hi = p.trajectory.state(t + eps);
    max_jump_a = std::max(max_jump_a, (hi.a_W - lo.a_W).norm());
    // Angular acceleration from one-sided differences on both sides of the knot.
    const Vec3 alpha_lo = (lo.omega_B - p.trajectory.state(t - 1e-4).omega_B) / (1e-4 - eps);
    const Vec3 alpha_hi = (p.trajectory.state(t + 1e-4).omega_B - hi.omega_B) / (1e-4 - eps);
    max_jump_alpha = std::max(max_jump_alpha, (alpha_hi - alpha_lo).norm());
  }
  EXPECT_LT(max_jump_a, 1e-4);      // a jump would be O(0.1 .. 10) m/s^2
  EXPECT_LT(max_jump_alpha, 0.05);  // rad/s^2; finite-difference slack of 1e-4 s * jerk
}

TEST(Trajectory, DerivativesMatchFiniteDifferencesOfPoses) {
  const Planned p(test::defaultScenario());
  const double h = 1e-4;
  for (double t = 0.713; t < p.trajectory.duration(); t += 3.3) {  // off the knots
    const BodyState s = p.trajectory.state(t);
    const BodyState a = p.trajectory.state(t - h), b = p.trajectory.state(t + h);
    EXPECT_LT((s.v_W - (b.T_W_B.translation() - a.T_W_B.translation()) / (2 * h)).norm(), 1e-5)
        << t;
    EXPECT_LT((s.a_W - (b.v_W - a.v_W) / (2 * h)).norm(), 1e-4) << t;
    const Vec3 omega_fd = so3::log(a.T_W_B.linear().transpose() * b.T_W_B.linear()) / (2 * h);
    EXPECT_LT((s.omega_B - omega_fd).norm(), 1e-5) << t;
  }
}

TEST(Trajectory, VineyardRowDrivesOneInterRowTurnsAndComesBackInTheNext) {
  const Scenario s = fromFile("vineyard_row");
  const Planned p(s);
  const SE3 start = p.trajectory.T_W_B(3.0),
            end = p.trajectory.T_W_B(p.trajectory.duration() - 3.0);
  EXPECT_NEAR(start.translation().y(), p.world.interrowY(s.trajectory.first_interrow), 0.15);
  EXPECT_NEAR(end.translation().y(), p.world.interrowY(s.trajectory.first_interrow + 1), 0.15);
  EXPECT_NEAR(yawOf(start), 0.0, 0.05);           // along +x
  EXPECT_NEAR(std::abs(yawOf(end)), M_PI, 0.05);  // back along -x
  EXPECT_GT(p.trajectory.T_W_B(p.trajectory.duration() / 2).translation().x(),
            s.world.row_length_m);  // headland
  EXPECT_NEAR(p.trajectory.duration(), 40.0, 4.0);
  // On a slope the body sits on the terrain: its z axis is the terrain normal (up to vibration).
  EXPECT_GT(start.linear().col(2).dot(p.world.groundNormal()), 0.999);
}

TEST(Trajectory, PureRotationTurnsAFullCircleInPlace) {
  const Scenario s = fromFile("pure_rotation");
  const Planned p(s);
  double yaw = 0.0, max_offset = 0.0;
  std::optional<Vec3> spin_start;
  const double dt = 0.01;
  for (double t = 0.0; t < p.trajectory.duration(); t += dt) {
    const BodyState st = p.trajectory.state(t);
    const double yaw_rate = (st.T_W_B.linear() * st.omega_B).z();
    yaw += yaw_rate * dt;
    if (std::abs(yaw_rate) > 0.2) {  // turning: the body stays on the spot (ride bumps aside)
      if (!spin_start) spin_start = st.T_W_B.translation();
      const Vec3 d = st.T_W_B.translation() - *spin_start;
      max_offset = std::max(max_offset, std::hypot(d.x(), d.y()));
    }
  }
  EXPECT_NEAR(yaw, 2.0 * M_PI, 0.05);
  ASSERT_TRUE(spin_start);
  EXPECT_LT(max_offset, 0.01);
}

TEST(Trajectory, StandstillStopsCompletelyAndRestarts) {
  const Planned p(fromFile("standstill"));
  int stops = 0;
  double still_since = -1.0;
  bool moved = false;
  for (double t = 0.0; t < p.trajectory.duration(); t += 0.01) {
    const BodyState st = p.trajectory.state(t);
    const bool still = st.v_W.norm() < 1e-9 && st.omega_B.norm() < 1e-9;
    if (!still) {
      if (moved && still_since >= 0.0 && t - still_since > 1.0) ++stops;
      moved = true;
      still_since = -1.0;
    } else if (still_since < 0.0) {
      still_since = t;
    }
  }
  EXPECT_GE(stops, 2);
}

// Issue 59: a working session. At least 8 rows of at least 60 m, U-turns at alternating
// headlands, a few stops, at least 600 m; the realities of vineyard_real all on.
TEST(Trajectory, VineyardBlockIsAWholeBlockWithTheRealitiesOfARealRun) {
  const Scenario s = fromFile("vineyard_block");
  const Scenario real = fromFile("vineyard_real");
  EXPECT_GE(s.trajectory.passes, 8);
  EXPECT_GE(s.world.row_length_m, 60.0);
  EXPECT_GE(s.world.num_rows, s.trajectory.first_interrow + s.trajectory.passes + 1);
  EXPECT_EQ(s.world.ground_roughness_m, real.world.ground_roughness_m);
  EXPECT_EQ(s.world.wind_amplitude_m, real.world.wind_amplitude_m);
  EXPECT_GT(s.world.grade_pct, 0.0);
  EXPECT_GT(s.world.side_tilt_pct, 0.0);
  EXPECT_EQ(s.camera.time_offset_s, real.camera.time_offset_s);
  EXPECT_EQ(s.camera.rolling_shutter_s, real.camera.rolling_shutter_s);
  EXPECT_EQ(s.camera.frame_drop_probability, real.camera.frame_drop_probability);
  EXPECT_TRUE(s.camera.auto_exposure);
  EXPECT_TRUE(s.lidar.sweep);

  const Planned p(s);
  double length = 0.0, still_since = -1.0;
  int stops = 0, direction = 0;
  Vec3 last = p.trajectory.T_W_B(0.0).translation();
  std::vector<double> uturn_x;  // where the heading reversed (the headland of each U-turn)
  for (double t = 0.0; t < p.trajectory.duration(); t += 0.02) {
    const BodyState st = p.trajectory.state(t);
    const Vec3 pos = st.T_W_B.translation();
    length += (pos - last).norm();
    last = pos;
    // Stops: standing still for more than a second between moves (not the start and end holds).
    const bool still = st.v_W.norm() < 1e-9;
    if (!still) {
      if (still_since > 2.0 && t - still_since > 1.0) ++stops;
      still_since = -1.0;
    } else if (still_since < 0.0) {
      still_since = t;
    }
    // Driving along +x or -x: a change of direction is a U-turn.
    const double along = st.T_W_B.linear()(0, 0);
    const int now = along > 0.9 ? 1 : along < -0.9 ? -1 : 0;
    if (now != 0 && direction != 0 && now != direction) uturn_x.push_back(pos.x());
    if (now != 0) direction = now;
  }
  EXPECT_GE(length, 600.0);
  EXPECT_GE(stops, 3);
  ASSERT_EQ(uturn_x.size(), static_cast<std::size_t>(s.trajectory.passes - 1));
  for (std::size_t k = 0; k < uturn_x.size(); ++k) {  // in the headlands, at alternating ends
    EXPECT_TRUE(uturn_x[k] < 0.0 || uturn_x[k] > s.world.row_length_m) << uturn_x[k];
    if (k > 0) {
      EXPECT_NE(uturn_x[k] < 0.0, uturn_x[k - 1] < 0.0) << k;
    }
  }
  // It ends in the row after the last: 8 inter-rows driven, one after the other.
  const SE3 end = p.trajectory.T_W_B(p.trajectory.duration() - 2.0);
  EXPECT_NEAR(end.translation().y(),
              p.world.interrowY(s.trajectory.first_interrow + s.trajectory.passes - 1), 0.3);
}

TEST(Trajectory, SeedJittersTheMotion) {
  Scenario a = test::defaultScenario(), b = test::defaultScenario();
  b.seed = 2;
  const Planned pa(a), pb(b);
  const double d =
      (pa.trajectory.T_W_B(10.0).translation() - pb.trajectory.T_W_B(10.0).translation()).norm();
  EXPECT_GT(d, 1e-3);
  EXPECT_LT(d, 1.0);
}

}  // namespace
}  // namespace ovo::sim
