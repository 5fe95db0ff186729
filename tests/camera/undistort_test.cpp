// OCamCalib-style perspective and panoramic undistortion against the toolbox's own outputs.
#include "camera/undistort.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/calib_io.hpp"
#include "tests/test_support.hpp"

namespace ovo::camera {
namespace {

cv::Mat applyTable(const cv::Mat& image, const RemapTable& table) {
  const cv::Mat map_u(table.height, table.width, CV_32F, const_cast<float*>(table.map_u.data()));
  const cv::Mat map_v(table.height, table.width, CV_32F, const_cast<float*>(table.map_v.data()));
  cv::Mat out;
  cv::remap(image, out, map_u, map_v, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

double meanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::mean(diff)[0];
}

TEST(Undistort, PerspectiveReproducesToolboxOutput) {
  OVO_REQUIRE_DATA("ocam-scaramuzza-sample/undistorted_perspective.jpg");
  const auto dir = test::sharedData("ocam-scaramuzza-sample");
  // The golden image was made with the file's own invpol: no refit here.
  const Camera cam = readOcamCalib(dir / "calib_results_fisheye.txt", {.refit_invpol = false});
  const cv::Mat input = cv::imread((dir / "test_fisheye.jpg").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat golden =
      cv::imread((dir / "undistorted_perspective.jpg").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(input.empty());
  ASSERT_EQ(golden.size(), input.size());
  const cv::Mat out = applyTable(input, perspectiveUndistortionMap(cam, 4.0));
  const double mad = meanAbsDiff(out, golden);
  // With the refit invpol the view moves by less than the file invpol's 0.01 px error.
  const Camera refit = readOcamCalib(dir / "calib_results_fisheye.txt");
  const double mad_refit =
      meanAbsDiff(applyTable(input, perspectiveUndistortionMap(refit, 4.0)), golden);
  std::printf(
      "[undistort] perspective sf=4: mean |out - toolbox| = %.3f grey levels (refit invpol: "
      "%.3f)\n",
      mad, mad_refit);
  EXPECT_LE(mad, 3.0);
  // A wrong scale factor or a swapped centre must not pass.
  EXPECT_GT(meanAbsDiff(applyTable(input, perspectiveUndistortionMap(cam, 3.0)), golden), 2 * mad);
}

TEST(Undistort, PanoramicReproducesToolboxOutput) {
  OVO_REQUIRE_DATA("ocam-scaramuzza-sample/undistorted_panoramic.jpg");
  const auto dir = test::sharedData("ocam-scaramuzza-sample");
  const OcamCamera cam = readOcamCalib(dir / "calib_results_catadioptric.txt");
  const cv::Mat input = cv::imread((dir / "test_catadioptric.jpg").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat golden =
      cv::imread((dir / "undistorted_panoramic.jpg").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(input.empty());
  ASSERT_EQ(golden.cols, 1200);
  ASSERT_EQ(golden.rows, 400);
  const auto table = panoramicUndistortionMap(cam.params().center_row, cam.params().center_col,
                                              20.0, 470.0, 1200, 400);
  const double mad = meanAbsDiff(applyTable(input, table), golden);
  std::printf("[undistort] panoramic 1200x400 rmin 20 rmax 470: mean |out - toolbox| = %.3f\n",
              mad);
  EXPECT_LE(mad, 3.0);
}

TEST(Undistort, PerspectiveViewOfAPinholeIsTheIdentityAtMatchingFocalLength) {
  // For an ideal pinhole with f = W / sf the perspective view samples every pixel at itself.
  const double sf = 2.0;
  const Camera cam = PinholeRadtanCamera(320.0, 320.0, 320.0, 240.0, 640, 480);
  const RemapTable t = perspectiveUndistortionMap(cam, sf);
  for (int i = 0; i < 480; i += 7)
    for (int j = 0; j < 640; j += 7) {
      EXPECT_NEAR(t.map_u[i * 640 + j], j, 1e-3);
      EXPECT_NEAR(t.map_v[i * 640 + j], i, 1e-3);
    }
}

}  // namespace
}  // namespace ovo::camera

namespace ovo::camera {
namespace {

bool ovoBuilt() {
  const char* bin = std::getenv("OVO_BIN");
  return std::filesystem::exists(bin ? bin : OVO_BINARY_DIR "/ovo");
}

TEST(UndistortCommand, WritesTheToolboxPerspectiveViewAndRejectsBadInput) {
  OVO_REQUIRE_DATA("ocam-scaramuzza-sample/undistorted_perspective.jpg");
  if (!ovoBuilt()) GTEST_SKIP() << "build/ovo not built";
  const auto dir = test::sharedData("ocam-scaramuzza-sample");
  const auto out = test::tempDir() / "persp.png";
  std::string err;
  ASSERT_EQ(test::runOvo("undistort --calib " + (dir / "calib_results_fisheye.txt").string() +
                             " --image " + (dir / "test_fisheye.jpg").string() + " --out " +
                             out.string() + " --sf 4",
                         nullptr, &err),
            0)
      << err;
  const cv::Mat golden =
      cv::imread((dir / "undistorted_perspective.jpg").string(), cv::IMREAD_GRAYSCALE);
  EXPECT_LE(meanAbsDiff(cv::imread(out.string(), cv::IMREAD_GRAYSCALE), golden), 3.0);

  const auto bad = test::tempDir() / "not_an_image.jpg";
  std::ofstream(bad) << "not a jpeg";
  EXPECT_EQ(test::runOvo("undistort --calib " + (dir / "calib_results_fisheye.txt").string() +
                             " --image " + bad.string() + " --out " + out.string(),
                         nullptr, &err),
            2);
  EXPECT_NE(err.find("not_an_image.jpg"), std::string::npos) << err;
  EXPECT_EQ(test::runOvo("undistort --calib " + (dir / "missing.txt").string() + " --image " +
                             (dir / "test_fisheye.jpg").string() + " --out " + out.string(),
                         nullptr, &err),
            2);
  EXPECT_NE(err.find("missing.txt"), std::string::npos) << err;
  // Absurd sizes: an error naming the option (100000 x 100000 ran out of memory: exit 3).
  const std::string good = "undistort --calib " + (dir / "calib_results_fisheye.txt").string() +
                           " --image " + (dir / "test_fisheye.jpg").string() + " --out " +
                           out.string();
  EXPECT_EQ(test::runOvo(good + " --panoramic --width 100000 --height 100000", nullptr, &err), 2);
  EXPECT_NE(err.find("--width/--height: expected a size of 1 to 20000"), std::string::npos) << err;
  EXPECT_EQ(test::runOvo(good + " --panoramic --rmax 1e300", nullptr, &err), 2);
  EXPECT_NE(err.find("--rmin/--rmax"), std::string::npos) << err;
  EXPECT_EQ(test::runOvo(good + " --sf inf", nullptr, &err), 2);
  EXPECT_NE(err.find("--sf: expected a scale factor in [0.01, 10000]"), std::string::npos) << err;
}

}  // namespace
}  // namespace ovo::camera
