// Agreement with evo on evo's own test data (../shared/data/traj-eval-evo, MANIFEST.md there).
// Expected numbers come from MANIFEST.md and from evo's saved results in res_files/: the
// stats.json files, and error_array.npz inside orb_ape.zip / orb_rpe.zip (raw .npy float64
// arrays, read by hand with python3's zipfile + struct).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "eval/metrics.hpp"
#include "io/trajectory_io.hpp"
#include "tests/test_support.hpp"

namespace ovo::eval {
namespace {

using test::sharedData;

Associated loadKitti00(const std::string& est_name) {
  const auto gt = io::readTrajectory(sharedData("traj-eval-evo/KITTI_00_gt.txt"));
  const auto est = io::readTrajectory(sharedData("traj-eval-evo/" + est_name));
  EXPECT_EQ(gt.format, io::TrajectoryFormat::kKitti);
  EXPECT_FALSE(gt.has_time);
  return associateByIndex(gt.poses, est.poses);
}

// `evo_ape kitti KITTI_00_gt.txt KITTI_00_ORB.txt -a` (translation part, SE(3) Umeyama).
TEST(EvoAgreement, ApeKitti00OrbSe3MatchesEvo) {
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  const Associated pairs = loadKitti00("KITTI_00_ORB.txt");
  ASSERT_EQ(pairs.size(), 4541u);
  const auto ate = computeAte(pairs, AlignMode::kSE3);
  ASSERT_TRUE(ate);
  EXPECT_NEAR(ate->trans_m.rmse, 1.3034497145650266, 1e-6);
  EXPECT_NEAR(ate->trans_m.mean, 1.1569971285389768, 1e-6);
  EXPECT_NEAR(ate->trans_m.median, 1.065624769555848, 1e-6);
  EXPECT_NEAR(ate->trans_m.max, 3.587949120678954, 1e-6);
  // res_files/orb_ape/stats.json
  EXPECT_NEAR(ate->trans_m.min, 0.06931322021483087, 1e-6);
  EXPECT_NEAR(ate->trans_m.std, 0.6002822693968323, 1e-6);
  EXPECT_NEAR(ate->trans_m.sse, 7715.073440292808, 1e-4);
  // res_files/orb_ape.zip error_array.npz: elements 0, 1, 2 and 4540.
  ASSERT_EQ(ate->errors_m.size(), 4541u);
  EXPECT_NEAR(ate->errors_m[0], 3.587949120678954, 1e-6);
  EXPECT_NEAR(ate->errors_m[1], 3.390188767907838, 1e-6);
  EXPECT_NEAR(ate->errors_m[2], 3.2295525382178187, 1e-6);
  EXPECT_NEAR(ate->errors_m[4540], 1.5977156481035328, 1e-6);
  EXPECT_DOUBLE_EQ(ate->alignment.scale, 1.0);
}

// `evo_rpe kitti KITTI_00_gt.txt KITTI_00_ORB.txt -d 10 -u m` (translation part, consecutive
// pairs, not aligned). evo picks the pairs on the estimate's path: on the reference path there
// would be 356 pairs, not evo's 353.
TEST(EvoAgreement, RpeKitti00Orb10mMatchesEvo) {
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  const Associated pairs = loadKitti00("KITTI_00_ORB.txt");
  RpeOptions options;
  options.delta = 10.0;
  options.unit = DeltaUnit::kMeters;
  const auto rpe = computeRpe(pairs, options);
  ASSERT_TRUE(rpe);
  ASSERT_EQ(rpe->id_pairs.size(), 353u);
  EXPECT_NEAR(rpe->trans.rmse, 0.22626134329310163, 1e-6);
  EXPECT_NEAR(rpe->trans.mean, 0.16901737200653275, 1e-6);
  // res_files/orb_rpe/stats.json
  EXPECT_NEAR(rpe->trans.median, 0.13848432516645606, 1e-6);
  EXPECT_NEAR(rpe->trans.max, 1.2722090778658726, 1e-6);
  EXPECT_NEAR(rpe->trans.min, 0.025322719660754993, 1e-6);
  EXPECT_NEAR(rpe->trans.std, 0.1504238127053164, 1e-6);
  EXPECT_NEAR(rpe->trans.sse, 18.07155100048597, 1e-5);
  // res_files/orb_rpe.zip error_array.npz: elements 0, 1, 2, 352 and the maximum at 217.
  EXPECT_NEAR(rpe->trans_m[0], 0.19126462050391924, 1e-6);
  EXPECT_NEAR(rpe->trans_m[1], 0.13942071603243775, 1e-6);
  EXPECT_NEAR(rpe->trans_m[2], 0.46846717111297004, 1e-6);
  EXPECT_NEAR(rpe->trans_m[352], 0.09122362175656828, 1e-6);
  EXPECT_NEAR(rpe->trans_m[217], 1.2722090778658726, 1e-6);

  options.pairs_from_reference = true;
  const auto rpe_ref = computeRpe(pairs, options);
  ASSERT_TRUE(rpe_ref);
  EXPECT_EQ(rpe_ref->id_pairs.size(), 356u);
}

// KITTI's segment errors (the odometry devkit's evaluate_odometry, at the lengths field robots
// report) written out the plain way: every 10th first frame, the first frame whose ground-truth
// path length from it exceeds L by a linear search, the pose error inverse(dP) dQ.
TEST(EvoAgreement, SegmentErrorsOnKitti00MatchAPlainDevkitComputation) {
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  const Associated pairs = loadKitti00("KITTI_00_ORB.txt");
  const auto seg = segmentErrors(pairs);
  ASSERT_EQ(seg.size(), kSegmentLengthsM.size());
  std::vector<double> dist = {0.0};
  for (std::size_t i = 1; i < pairs.size(); ++i)
    dist.push_back(dist.back() + (pairs.ref[i].T_W_B.translation() -
                                   pairs.ref[i - 1].T_W_B.translation())
                                     .norm());
  for (const auto& s : seg) {
    const double L = s.length_m;
    double t_sum = 0.0, r_sum = 0.0;
    std::size_t count = 0;
    for (std::size_t first = 0; first < pairs.size(); first += 10) {
      std::size_t last = first;
      while (last < pairs.size() && dist[last] <= dist[first] + L) ++last;
      if (last == pairs.size()) continue;
      const SE3 dQ = pairs.ref[first].T_W_B.inverse() * pairs.ref[last].T_W_B;
      const SE3 dP = pairs.est[first].T_W_B.inverse() * pairs.est[last].T_W_B;
      const SE3 E = dP.inverse() * dQ;
      t_sum += E.translation().norm() / L;
      r_sum += Eigen::AngleAxisd(E.linear()).angle() * 180.0 / M_PI / L;
      ++count;
    }
    ASSERT_GT(count, 0u);
    EXPECT_EQ(s.count, count) << L;
    EXPECT_NEAR(s.trans_pct, 100.0 * t_sum / count, 1e-6) << L;
    EXPECT_NEAR(s.rot_deg_per_100m, 100.0 * r_sum / count, 1e-6) << L;
  }
  // The devkit's own drift (100-800 m) for this estimate, stereo ORB-SLAM2 on 00, is published
  // as 0.70 % and 0.25 deg / 100 m (Mur-Artal and Tardos, T-RO 2017, table 2); the short
  // segments carry more of the per-frame noise.
  const auto drift = kittiDrift(pairs);
  ASSERT_TRUE(drift);
  EXPECT_NEAR(drift->trans_pct, 0.70, 0.005);
  EXPECT_NEAR(100.0 * drift->rot_deg_per_m, 0.25, 0.005);
  std::printf("KITTI 00 ORB: devkit drift %.3f %%, %.3f deg/100 m; segments:", drift->trans_pct,
              100.0 * drift->rot_deg_per_m);
  for (const auto& s : seg)
    std::printf(" %g m %.3f %% %.3f deg/100m;", s.length_m, s.trans_pct, s.rot_deg_per_100m);
  std::printf("\n");
}

TEST(EvoAgreement, Sim3AteOnKitti00IsNoWorseThanSe3) {
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  for (const char* name : {"KITTI_00_ORB.txt", "KITTI_00_SPTAM.txt"}) {
    const Associated pairs = loadKitti00(name);
    const auto se3 = computeAte(pairs, AlignMode::kSE3);
    const auto sim3 = computeAte(pairs, AlignMode::kSim3);
    const auto none = computeAte(pairs, AlignMode::kNone);
    ASSERT_TRUE(se3 && sim3 && none) << name;
    EXPECT_LE(sim3->trans_m.rmse, se3->trans_m.rmse + 1e-12) << name;
    EXPECT_LE(se3->trans_m.rmse, none->trans_m.rmse + 1e-12) << name;
    EXPECT_NEAR(sim3->alignment.scale, 1.0, 0.05) << name;  // stereo methods: metric scale
  }
}

// evo's nearest-stamp rule written the slow, obvious way: for each stamp of the shorter
// trajectory, the first argmin over the longer one.
std::size_t bruteForceMatches(const Trajectory& ref, const Trajectory& est, Timestamp max_diff) {
  const bool est_longer = est.size() > ref.size();
  const Trajectory& s = est_longer ? ref : est;
  const Trajectory& l = est_longer ? est : ref;
  std::size_t n = 0;
  for (const auto& p : s) {
    Timestamp best = std::numeric_limits<Timestamp>::max();
    for (const auto& q : l) best = std::min<Timestamp>(best, std::llabs(q.t_ns - p.t_ns));
    if (best <= max_diff) ++n;
  }
  return n;
}

struct TumPair {
  const char* gt;
  const char* est;
  io::TrajectoryFormat gt_format;
};

TEST(EvoAgreement, TumPairsAssociateLikeEvoAndSim3IsNoWorseThanSe3) {
  OVO_REQUIRE_DATA("traj-eval-evo/freiburg1_xyz-groundtruth.txt");
  const TumPair cases[] = {
      {"freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt", io::TrajectoryFormat::kTum},
      {"fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt", io::TrajectoryFormat::kTum},
      {"V102_groundtruth.csv", "V102.txt", io::TrajectoryFormat::kEurocCsv}};
  for (const auto& c : cases) {
    const auto gt = io::readTrajectory(sharedData(std::string("traj-eval-evo/") + c.gt));
    const auto est = io::readTrajectory(sharedData(std::string("traj-eval-evo/") + c.est));
    EXPECT_EQ(gt.format, c.gt_format) << c.gt;
    EXPECT_EQ(est.format, io::TrajectoryFormat::kTum) << c.est;
    const Associated pairs = associateByTime(gt.poses, est.poses, 20'000'000);
    EXPECT_EQ(pairs.size(), bruteForceMatches(gt.poses, est.poses, 20'000'000)) << c.est;
    EXPECT_GT(pairs.size(), est.poses.size() / 2) << c.est;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      ASSERT_LE(std::llabs(pairs.ref[i].t_ns - pairs.est[i].t_ns), 20'000'000) << c.est;
    const auto se3 = computeAte(pairs, AlignMode::kSE3);
    const auto sim3 = computeAte(pairs, AlignMode::kSim3);
    ASSERT_TRUE(se3 && sim3) << c.est;
    EXPECT_LE(sim3->trans_m.rmse, se3->trans_m.rmse + 1e-12) << c.est;
    std::printf("%s: %zu of %zu poses matched, ATE se3 %.6f m, sim3 %.6f m (scale %.4f)\n", c.est,
                pairs.size(), est.poses.size(), se3->trans_m.rmse, sim3->trans_m.rmse,
                sim3->alignment.scale);
  }
}

}  // namespace
}  // namespace ovo::eval
