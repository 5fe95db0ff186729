// The batched 8-point hypothesis solver (gpu/hypotheses.hpp) and the thread pool
// (gpu/thread_pool.hpp): exact on noise-free samples in every lane, the same bits whatever the
// lane grouping or range split, failed lanes zero without touching the others, every pool task
// run exactly once.
#include "gpu/hypotheses.hpp"

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <limits>
#include <thread>

#include "frontend/essential.hpp"
#include "gpu/thread_pool.hpp"
#include "tests/gpu/two_view_scene.hpp"

namespace ovo::gpu {
namespace {

constexpr int L = kEightPointLanes;

test::TwoViewScene scene(double outlier_ratio, double noise_px, std::uint64_t seed,
                         Vec3 t = Vec3(0.15, -0.05, -0.5)) {
  test::TwoViewSceneOptions o;
  o.num_matches = 200;
  o.outlier_ratio = outlier_ratio;
  o.noise_px = noise_px;
  o.max_off_axis_deg = 110.0;
  o.t_cur_prev = t;
  o.seed = seed;
  return test::makeTwoViewScene(o);
}

TEST(Hypotheses, EveryLaneIsExactOnItsOwnNoiseFreeSample) {
  // Each lane gets a different scene (a different motion), so lanes cannot borrow each other's.
  double prev[8][3][L], cur[8][3][L], E[9][L];
  bool valid[L];
  std::vector<Mat3> truth;
  for (int l = 0; l < L; ++l) {
    test::TwoViewSceneOptions o;
    o.num_matches = 8;
    o.outlier_ratio = 0.0;
    o.noise_px = 0.0;
    o.max_off_axis_deg = 115.0;
    o.R_cur_prev = so3::exp(Vec3(0.05 * l, -0.1, 0.02 * l));
    o.t_cur_prev = Vec3(0.3 - 0.1 * l, 0.1, l % 2 ? 0.5 : -0.5);
    o.seed = 50 + l;
    const auto s = test::makeTwoViewScene(o);
    truth.push_back(frontend::essentialFromMotion(s.R_cur_prev, s.t_cur_prev.normalized()));
    for (int j = 0; j < 8; ++j)
      for (int r = 0; r < 3; ++r) {
        prev[j][r][l] = s.b_prev[j](r);
        cur[j][r][l] = s.b_cur[j](r);
      }
  }
  eightPointLanes(prev, cur, E, valid);
  for (int l = 0; l < L; ++l) {
    ASSERT_TRUE(valid[l]) << "lane " << l;
    Mat3 M;
    for (int j = 0; j < 9; ++j) M(j / 3, j % 3) = E[j][l];
    EXPECT_LT(std::min((M - truth[l]).norm(), (M + truth[l]).norm()), 1e-9) << "lane " << l;
  }
}

TEST(Hypotheses, NoisySolutionsHaveSingularValuesOneOneZero) {
  const auto s = scene(0.3, 2.0, 8);
  const test::SoAd soa = test::toSoAd(s);
  std::vector<float> E(9 * 64);
  generateHypothesesCpu(soa.view(), 3, 0, 64, E.data());
  for (int h = 0; h < 64; ++h) {
    Mat3 M;
    for (int j = 0; j < 9; ++j) M(j / 3, j % 3) = E[9 * h + j];
    const Vec3 sv = Eigen::JacobiSVD<Mat3>(M).singularValues();
    EXPECT_NEAR(sv(0), 1.0, 1e-6) << h;
    EXPECT_NEAR(sv(1), 1.0, 1e-6) << h;
    EXPECT_NEAR(sv(2), 0.0, 1e-6) << h;
  }
}

TEST(Hypotheses, SameBitsWhateverTheRangeSplitAndAsTheSingleSolve) {
  const auto s = scene(0.3, 0.5, 9);
  const test::SoAd soa = test::toSoAd(s);
  const int count = 45;  // not a multiple of the lane count
  std::vector<float> whole(9 * count), split(9 * count);
  generateHypothesesCpu(soa.view(), 7, 0, count, whole.data());
  generateHypothesesCpu(soa.view(), 7, 0, 13, split.data());
  generateHypothesesCpu(soa.view(), 7, 13, 14, split.data() + 9 * 13);
  generateHypothesesCpu(soa.view(), 7, 14, count, split.data() + 9 * 14);
  EXPECT_EQ(std::memcmp(whole.data(), split.data(), whole.size() * sizeof(float)), 0);
  for (int h = 0; h < count; ++h) {
    const auto idx = sampleIndices(7, h, 200);
    std::array<Vec3, 8> bp, bc;
    for (int j = 0; j < 8; ++j) {
      bp[j] = s.b_prev[idx[j]];
      bc[j] = s.b_cur[idx[j]];
    }
    const Mat3 M = frontend::eightPointMinimal(bp, bc).value_or(Mat3::Zero());
    for (int j = 0; j < 9; ++j)
      EXPECT_EQ(static_cast<float>(M(j / 3, j % 3)), whole[9 * h + j]) << "h " << h << " j " << j;
  }
}

TEST(Hypotheses, NonFiniteLaneIsZeroAndLeavesTheOthersAlone) {
  const auto s = scene(0.0, 0.0, 10);
  double prev[8][3][L], cur[8][3][L], E[9][L], E_clean[9][L];
  bool valid[L], valid_clean[L];
  for (int j = 0; j < 8; ++j)
    for (int r = 0; r < 3; ++r)
      for (int l = 0; l < L; ++l) {
        prev[j][r][l] = s.b_prev[j + l](r);
        cur[j][r][l] = s.b_cur[j + l](r);
      }
  eightPointLanes(prev, cur, E_clean, valid_clean);
  prev[3][1][2] = std::numeric_limits<double>::quiet_NaN();
  for (int r = 0; r < 3; ++r) cur[5][r][4] = 0.0;  // a zero bearing: rank-deficient, still solves
  eightPointLanes(prev, cur, E, valid);
  EXPECT_FALSE(valid[2]);
  for (int j = 0; j < 9; ++j) EXPECT_EQ(E[j][2], 0.0);
  for (int l = 0; l < L; ++l) {
    if (l == 2 || l == 4) continue;
    EXPECT_TRUE(valid[l]);
    for (int j = 0; j < 9; ++j) EXPECT_EQ(E[j][l], E_clean[j][l]) << "lane " << l;
  }
  for (int j = 0; j < 9; ++j) EXPECT_TRUE(std::isfinite(E[j][4]));
}

TEST(ThreadPool, RunsEveryTaskExactlyOnceOverManyJobs) {
  ThreadPool pool(3);
  EXPECT_EQ(pool.concurrency(), 4);
  for (int job = 0; job < 300; ++job) {
    const int tasks = 1 + job % 37;
    std::vector<std::atomic<int>> hits(tasks);
    pool.run(tasks, [&](int t) { hits[t].fetch_add(1); });
    for (int t = 0; t < tasks; ++t) ASSERT_EQ(hits[t].load(), 1) << "job " << job << " task " << t;
  }
}

TEST(ThreadPool, RestingWorkersWakeForTheNextJob) {
  ThreadPool pool(2);
  int jobs_shared = 0;  // jobs whose tasks ran on more than the calling thread
  for (int job = 0; job < 20; ++job) {
    pool.rest();
    std::vector<std::atomic<int>> hits(8);
    std::vector<std::thread::id> ran_on(8);
    pool.run(8, [&](int t) {
      ran_on[t] = std::this_thread::get_id();
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      hits[t].fetch_add(1);
    });
    for (int t = 0; t < 8; ++t) ASSERT_EQ(hits[t].load(), 1) << "job " << job << " task " << t;
    jobs_shared += std::count(ran_on.begin(), ran_on.end(), std::this_thread::get_id()) < 8;
  }
  EXPECT_GT(jobs_shared, 0);
}

TEST(ThreadPool, ConcurrentCallersAreServedOneAtATime) {
  ThreadPool pool(2);
  std::atomic<long> sum{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 3; ++c)
    callers.emplace_back([&] {
      for (int job = 0; job < 50; ++job) pool.run(16, [&](int t) { sum.fetch_add(t + 1); });
    });
  for (auto& t : callers) t.join();
  EXPECT_EQ(sum.load(), 3L * 50 * (16 * 17 / 2));
}

}  // namespace
}  // namespace ovo::gpu
