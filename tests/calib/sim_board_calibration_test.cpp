// The simulator's checkerboard scene calibrated end to end (render, detect, calibrate): the
// calibrated OCam model's bearings against the true RoMoVi model over the whole valid image.
#include <gtest/gtest.h>

#include "calib/board_detector.hpp"
#include "calib/camera_calibration.hpp"
#include "calib/model_comparison.hpp"
#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "sim/board_scene.hpp"
#include "tests/test_support.hpp"

namespace ovo::calib {
namespace {

TEST(SimBoardCalibration, RomoviBearingsWithinFiveHundredthsOfADegree) {
  // configs/sim/checkerboard.yaml with 3 x 3 instead of 4 x 4 samples a pixel (time).
  Config config = Config::load(ovo::test::sourcePath("configs/sim/checkerboard.yaml"));
  config.applyOverride("render.supersample=3");
  const sim::BoardSceneOptions options = sim::readBoardScene(config);
  const camera::Camera truth = camera::loadCamera(options.calibration);
  const auto views = sim::boardViews(truth, options);
  std::vector<BoardObservation> boards;
  for (std::size_t k = 0; k < views.size(); ++k) {
    const cv::Mat image = sim::renderBoardView(truth, options, views[k], static_cast<int>(k));
    const Detection d = detectBoard(image, {options.cols, options.rows, options.square_m},
                                    "view_" + std::to_string(k));
    ASSERT_TRUE(d.board) << k << ": " << d.reason;
    boards.push_back(*d.board);
  }
  const CalibrationResult r = calibrateCamera(boards, {});
  EXPECT_TRUE(r.rejected.empty());
  EXPECT_LT(r.rms_px, 0.12);
  const BearingComparison c = compareBearings(truth, *r.camera, 4);
  std::printf("sim board: rms %.3f px, bearings within %.4f deg (%.4f unaligned, roll %.4f)\n",
              r.rms_px, c.max_deg, c.max_unaligned_deg, c.roll_deg);
  EXPECT_EQ(c.missing, 0);
  EXPECT_LT(c.max_deg, 0.05);
  // The roll is the affine's gauge: the true model's d and e hold a 0.047 deg rotation.
  EXPECT_NEAR(c.roll_deg, -0.047, 0.02);
}

}  // namespace
}  // namespace ovo::calib
