// Every RANSAC backend evaluates the same hypotheses and returns the same model and inlier set,
// bit for bit, on simulated wide-angle matches and on real KITTI matches (with a rotation check
// against the KITTI ground truth).
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/so3.hpp"
#include "frontend/ransac.hpp"
#include "frontend/relative_pose.hpp"
#include "gpu/opencl_context.hpp"
#include "tests/gpu/two_view_scene.hpp"
#include "tests/test_support.hpp"

namespace ovo::frontend {
namespace {

std::vector<std::string> backendNames() {
  std::vector<std::string> names = {"serial", "threads"};
  if (gpu::OpenClContext::shared()) names.push_back("opencl");
  return names;
}

void expectIdentical(const RelativePoseResult& a, const RelativePoseResult& b,
                     const std::string& what) {
  EXPECT_EQ(a.status, b.status) << what;
  EXPECT_EQ(a.iterations, b.iterations) << what;
  EXPECT_EQ(a.num_inliers, b.num_inliers) << what;
  EXPECT_EQ(a.inliers, b.inliers) << what;
  // Bitwise equal: the same arithmetic on the same winner.
  EXPECT_TRUE((a.R_cur_prev.array() == b.R_cur_prev.array()).all()) << what;
  EXPECT_TRUE((a.t_cur_prev.array() == b.t_cur_prev.array()).all()) << what;
}

void compareBackends(const std::vector<Vec3>& bp, const std::vector<Vec3>& bc,
                     RelativePoseOptions options, const std::string& what,
                     RelativePoseResult* serial_result = nullptr) {
  std::vector<RelativePoseResult> results;
  std::vector<std::vector<int>> counts;
  RansacOptions ro;
  ro.max_iterations = options.max_iterations;
  ro.adaptive = options.adaptive;
  ro.inlier_threshold_rad = options.inlier_threshold_rad;
  ro.seed = options.seed;
  for (const auto& name : backendNames()) {
    options.backend = name;
    RelativePoseEstimator estimator(options);
    ASSERT_EQ(estimator.backendName(), name);
    results.push_back(estimator.estimate(bp, bc));
    Ransac ransac(gpu::makeScoringBackend(name));
    ransac.run(bp, bc, ro);
    counts.push_back(ransac.lastCounts());
  }
  for (std::size_t k = 1; k < results.size(); ++k) {
    expectIdentical(results[0], results[k], what + ": serial vs " + backendNames()[k]);
    EXPECT_EQ(counts[0], counts[k])
        << what << ": hypothesis counts, serial vs " << backendNames()[k];
  }
  if (serial_result) *serial_result = results[0];
}

TEST(Backends, IdenticalModelsAndInlierSetsOnSimulatedMatches) {
  for (int n : {250, 1000}) {
    test::TwoViewSceneOptions so;
    so.num_matches = n;
    so.seed = 21 + n;
    const auto s = test::makeTwoViewScene(so);
    RelativePoseOptions o;
    o.inlier_threshold_rad = 4e-3;
    RelativePoseResult r;
    compareBackends(s.b_prev, s.b_cur, o, "simulated n=" + std::to_string(n), &r);
    EXPECT_EQ(r.status, RelativePoseResult::Status::kOk);
  }
}

TEST(Backends, AdaptiveStoppingStopsIdentically) {
  test::TwoViewSceneOptions so;
  so.num_matches = 600;
  so.outlier_ratio = 0.15;
  const auto s = test::makeTwoViewScene(so);
  RelativePoseOptions o;
  o.inlier_threshold_rad = 4e-3;
  o.adaptive = true;
  RelativePoseResult r;
  compareBackends(s.b_prev, s.b_cur, o, "adaptive", &r);
  EXPECT_LT(r.iterations, o.max_iterations);
}

// Real matches: Shi-Tomasi corners in KITTI 07 frame 0, found again in frame 1 by SSD template
// search (integer pixels, so real noise and real wrong matches), turned into pinhole bearings.
struct RealMatches {
  std::vector<Vec3> b_prev, b_cur;
  Mat3 R_cur_prev_gt;
};

RealMatches kittiMatches(int frame_prev, int frame_cur) {
  const auto dir = test::sharedData("kitti07-first160");
  auto image = [&](int k) {
    char name[32];
    std::snprintf(name, sizeof(name), "image_0/%06d.png", k);
    return cv::imread((dir / name).string(), cv::IMREAD_GRAYSCALE);
  };
  const cv::Mat img0 = image(frame_prev), img1 = image(frame_cur);
  std::ifstream calib(dir / "calib.txt");
  std::string tag;
  double P[12];
  calib >> tag;
  for (double& v : P) calib >> v;
  const double fx = P[0], cx = P[2], fy = P[5], cy = P[6];
  std::ifstream poses(dir / "poses_07_time_prefixed.txt");
  std::vector<Mat3> R_W_C;
  std::string line;
  while (std::getline(poses, line) && static_cast<int>(R_W_C.size()) <= frame_cur) {
    std::istringstream ls(line);
    double t, v[12];
    ls >> t;
    for (double& x : v) ls >> x;
    Mat3 R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    R_W_C.push_back(R);
  }
  RealMatches m;
  m.R_cur_prev_gt = R_W_C[frame_cur].transpose() * R_W_C[frame_prev];

  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(img0, corners, 700, 0.01, 10);
  const int half = 7, search_x = 40, search_y = 20;
  auto bearing = [&](double u, double v) {
    return Vec3((u - cx) / fx, (v - cy) / fy, 1.0).normalized();
  };
  for (const auto& c : corners) {
    const int u = cvRound(c.x), v = cvRound(c.y);
    if (u - half - search_x < 0 || v - half - search_y < 0 || u + half + search_x >= img0.cols ||
        v + half + search_y >= img0.rows)
      continue;
    const cv::Mat patch = img0(cv::Rect(u - half, v - half, 2 * half + 1, 2 * half + 1));
    const cv::Mat window = img1(cv::Rect(u - half - search_x, v - half - search_y,
                                         2 * (half + search_x) + 1, 2 * (half + search_y) + 1));
    cv::Mat cost;
    cv::matchTemplate(window, patch, cost, cv::TM_SQDIFF_NORMED);
    cv::Point best;
    cv::minMaxLoc(cost, nullptr, nullptr, &best, nullptr);
    m.b_prev.push_back(bearing(u, v));
    m.b_cur.push_back(bearing(u - search_x + best.x, v - search_y + best.y));
  }
  return m;
}

TEST(Backends, IdenticalModelsAndInlierSetsOnRealKittiMatches) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000002.png");
  const auto m = kittiMatches(0, 2);
  ASSERT_GT(m.b_prev.size(), 300u);
  RelativePoseOptions o;
  o.inlier_threshold_rad = 1.5 / 707.0;  // 1.5 px: integer-pixel matches
  // 1.1 m of forward driving gives only ~0.22 degrees of median rotation-compensated parallax.
  o.min_parallax_deg = 0.1;
  RelativePoseResult r;
  compareBackends(m.b_prev, m.b_cur, o, "kitti 0-2", &r);
  ASSERT_EQ(r.status, RelativePoseResult::Status::kOk)
      << toString(r.status) << " parallax " << r.median_parallax_deg << " inliers "
      << r.num_inliers;
  const double rot_err_deg = so3::angle(r.R_cur_prev.transpose() * m.R_cur_prev_gt) * 180.0 / M_PI;
  EXPECT_LT(rot_err_deg, 0.1);
  // Driving forward: a point ahead comes closer, X_cur = R X_prev + t with t along -z.
  EXPECT_LT(r.t_cur_prev.z(), -0.9);
  std::printf("kitti 0-2: %zu matches, %d inliers, rotation error %.4f deg, t = %.3f %.3f %.3f\n",
              m.b_prev.size(), r.num_inliers, rot_err_deg, r.t_cur_prev.x(), r.t_cur_prev.y(),
              r.t_cur_prev.z());
}

}  // namespace
}  // namespace ovo::frontend
