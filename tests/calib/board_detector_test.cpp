// Board detection: corners of rendered boards against their true pixels (in the image and in
// perspective views), the grid check, a wrong board size, and real fisheye images.
#include "calib/board_detector.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "calib/corners_file.hpp"
#include "sim/board_scene.hpp"
#include "tests/calib/calib_test_support.hpp"

namespace ovo::calib {
namespace {

sim::BoardSceneOptions sceneOptions(int views) {
  sim::BoardSceneOptions o;
  o.seed = 11;
  o.views = views;
  o.max_off_axis_deg = 90.0;
  return o;
}

// Mean and largest distance of detected corners from the true ones (same order).
std::pair<double, double> cornerErrors(const std::vector<Vec2>& found,
                                       const std::vector<Vec2>& truth) {
  double sum = 0.0, worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double e = (found[i] - truth[i]).norm();
    sum += e;
    worst = std::max(worst, e);
  }
  return {sum / truth.size(), worst};
}

// OpenCV may number the corners from either end of the board: align to the truth's order.
std::vector<Vec2> inTruthOrder(std::vector<Vec2> found, const std::vector<Vec2>& truth) {
  if ((found.front() - truth.front()).norm() > (found.back() - truth.front()).norm())
    std::reverse(found.begin(), found.end());
  return found;
}

TEST(BoardDetector, FindsRenderedBoardsToATenthOfAPixel) {
  const camera::Camera cam = test::romoviCamera();
  const auto options = sceneOptions(4);
  const auto views = sim::boardViews(cam, options);
  for (std::size_t k = 0; k < views.size(); ++k) {
    const cv::Mat image = sim::renderBoardView(cam, options, views[k], static_cast<int>(k));
    const Detection d = detectBoard(image, {options.cols, options.rows, options.square_m}, "view");
    ASSERT_TRUE(d.board) << "view " << k << ": " << d.reason;
    const auto [mean, worst] =
        cornerErrors(inTruthOrder(d.board->corners_px, views[k].corners_px), views[k].corners_px);
    EXPECT_LT(mean, 0.1) << "view " << k;
    EXPECT_LT(worst, 0.35) << "view " << k;
    EXPECT_EQ(d.board->points_B[options.cols + 1], Vec3(options.square_m, options.square_m, 0));
  }
}

TEST(BoardDetector, FindsABoardInPerspectiveViewsThroughAModel) {
  const camera::Camera cam = test::romoviCamera();
  const auto options = sceneOptions(1);
  const auto views = sim::boardViews(cam, options);
  const cv::Mat image = sim::renderBoardView(cam, options, views[0], 0);
  const Detection d =
      detectBoardInViews(image, {options.cols, options.rows, options.square_m}, "view", cam);
  ASSERT_TRUE(d.board) << d.reason;
  EXPECT_EQ(d.method, "perspective view");
  const auto [mean, worst] =
      cornerErrors(inTruthOrder(d.board->corners_px, views[0].corners_px), views[0].corners_px);
  EXPECT_LT(mean, 0.1);
  EXPECT_LT(worst, 0.35);
}

TEST(BoardDetector, AWrongBoardSizeIsNotFound) {
  const camera::Camera cam = test::romoviCamera();
  const auto options = sceneOptions(1);
  const auto views = sim::boardViews(cam, options);
  const cv::Mat image = sim::renderBoardView(cam, options, views[0], 0);
  const Detection d = detectBoard(image, {options.cols + 1, options.rows, 0.06}, "view");
  EXPECT_FALSE(d.board);
  EXPECT_NE(d.reason.find("no 10x6 board found"), std::string::npos) << d.reason;
}

TEST(BoardDetector, GridCheckRefusesImplausibleGrids) {
  const BoardSpec spec{5, 4, 0.05};
  std::vector<Vec2> grid;
  for (int j = 0; j < spec.rows; ++j)
    for (int i = 0; i < spec.cols; ++i) grid.emplace_back(100 + 30 * i + 0.5 * j, 80 + 28 * j);
  EXPECT_FALSE(gridProblem(grid, spec, 640, 480));
  auto swapped = grid;  // rows 1 and 2 exchanged: the grid folds
  for (int i = 0; i < spec.cols; ++i) std::swap(swapped[spec.cols + i], swapped[2 * spec.cols + i]);
  EXPECT_TRUE(gridProblem(swapped, spec, 640, 480));
  auto kinked = grid;  // one corner far off its row
  kinked[7].y() += 20.0;
  const auto p = gridProblem(kinked, spec, 640, 480);
  ASSERT_TRUE(p);
  EXPECT_NE(p->find("row 1"), std::string::npos) << *p;
  auto outside = grid;
  outside[0].x() = -3.0;
  EXPECT_NE(gridProblem(outside, spec, 640, 480)->find("outside the image"), std::string::npos);
}

TEST(BoardDetector, RealFisheyeCornersAgreeWithThePeerTool) {
  const char* kImage = "ocam-urban-checkerboards/fish_1/Fisheye1_1.jpg";
  const char* kCorners =
      "ocam-urban-checkerboards/pyocamcalib_corners_fisheye_1_09092022_decoded.txt";
  OVO_REQUIRE_DATA(kImage);
  OVO_REQUIRE_DATA(kCorners);
  const cv::Mat grey = cv::imread(ovo::test::sharedData(kImage).string(), cv::IMREAD_GRAYSCALE);
  const Detection d = detectBoard(grey, {8, 6, 0.0325}, "Fisheye1_1.jpg");
  ASSERT_TRUE(d.board) << d.reason;
  const auto peer = readCornersFile(ovo::test::sharedData(kCorners), 0.0325, 1032, 778);
  const auto [mean, worst] =
      cornerErrors(inTruthOrder(d.board->corners_px, peer[0].corners_px), peer[0].corners_px);
  EXPECT_LT(mean, 0.5);
  EXPECT_LT(worst, 1.5);
}

}  // namespace
}  // namespace ovo::calib
