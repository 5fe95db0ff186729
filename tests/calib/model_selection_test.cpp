// `ovo calibrate camera` picks its model by held-out error: synthetic boards of a camera whose
// true polynomial degree is known, at a realistic corner noise, and a board with worse corners.
#include "calib/model_selection.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "calib/model_comparison.hpp"
#include "tests/calib/calib_test_support.hpp"

namespace ovo::calib {
namespace {

const BoardSpec kLargeBoard{8, 6, 0.07};

std::vector<ModelCandidate> ocamDegrees(int lo, int hi) {
  std::vector<ModelCandidate> c;
  for (int d = lo; d <= hi; ++d) c.push_back({CameraModelKind::kOcam, d, BoardShape::kShared});
  return c;
}

void print(const ModelSelection& s) {
  for (std::size_t k = 0; k < s.scores.size(); ++k)
    std::printf("  %-32s params %2d train %.4f held-out %.4f%s\n",
                candidateName(s.scores[k].candidate).c_str(), s.scores[k].parameters,
                s.scores[k].train_rms_px, s.scores[k].heldout_rms_px,
                k == s.chosen ? "  <- chosen" : "");
}

// The RoMoVi lens with one more term: a0..a5, a degree-5 polynomial that degree 4 cannot follow.
camera::Camera degreeFiveCamera() {
  camera::OcamParams p = std::get<camera::OcamCamera>(test::romoviCamera()).params();
  p.ss.push_back(-6e-11);  // 0.05 px of misfit for degree 4 over the boards' coverage
  p.invpol.clear();
  return camera::OcamCamera(p);
}

// 0.1 px of corner noise: what cornerSubPix gives on sharp real boards (fish_2 fits to 0.11 px
// RMS, the rendered board to 0.07).
TEST(ModelSelection, PicksTheTrueDegreeFourAtARealisticCornerNoise) {
  const camera::Camera truth = test::romoviCamera();
  ASSERT_EQ(std::get<camera::OcamCamera>(truth).params().ss.size(), 5u);  // degree 4
  const auto boards = test::syntheticBoards(truth, kLargeBoard, 20, 110.0, 0.1, 7);
  ASSERT_EQ(boards.size(), 20u);
  const ModelSelection s = selectModel(boards, ocamDegrees(3, 6), {});
  print(s);
  ASSERT_EQ(s.scores.size(), 4u);
  EXPECT_EQ(s.scores[s.chosen].candidate.degree, 4) << s.reason;
  // Training error falls with the degree; the held-out error does not follow it.
  EXPECT_LE(s.scores[3].train_rms_px, s.scores[1].train_rms_px + 1e-9);
  EXPECT_GT(s.scores[0].heldout_rms_px, 1.2 * s.scores[1].heldout_rms_px);  // 3 underfits
  EXPECT_TRUE(s.outliers.empty());
  EXPECT_EQ(s.folds, 10);
}

TEST(ModelSelection, PicksTheTrueDegreeFive) {
  const camera::Camera truth = degreeFiveCamera();
  const auto boards = test::syntheticBoards(truth, kLargeBoard, 20, 110.0, 0.1, 8);
  ASSERT_GE(boards.size(), 16u);
  const ModelSelection s = selectModel(boards, ocamDegrees(3, 6), {});
  print(s);
  EXPECT_EQ(s.scores[s.chosen].candidate.degree, 5) << s.reason;
  EXPECT_GT(s.scores[1].heldout_rms_px, 1.02 * s.scores[2].heldout_rms_px);  // 4 underfits
}

TEST(ModelSelection, NamesABoardWhoseCornersAreClearlyWorse) {
  const camera::Camera truth = test::romoviCamera();
  auto boards = test::syntheticBoards(truth, kLargeBoard, 12, 110.0, 0.2, 9);
  ASSERT_EQ(boards.size(), 12u);
  // One view with 0.6 px of corner noise more (kept by the calibration's own rejection).
  auto worse = test::syntheticBoards(truth, kLargeBoard, 12, 110.0, 0.6, 9);
  boards[5] = worse[5];
  boards[5].image = "blurred.png";
  SelectionOptions options;
  options.max_folds = 12;
  const ModelSelection s = selectModel(boards, ocamDegrees(4, 4), {}, options);
  print(s);
  ASSERT_EQ(s.images.size(), 12u);  // not rejected by the calibration
  ASSERT_EQ(s.outliers.size(), 1u);
  EXPECT_EQ(s.outliers[0], "blurred.png");
  EXPECT_EQ(s.folds, 12);  // leave-one-image-out
}

TEST(ModelSelection, TooFewBoardsToLeaveOneOutTakeTheDefaultAndSaySo) {
  const camera::Camera truth = test::romoviCamera();
  const auto boards = test::syntheticBoards(truth, kLargeBoard, 3, 110.0, 0.1, 11);
  ASSERT_EQ(boards.size(), 3u);  // min_boards: leaving one out leaves too few
  const ModelSelection s = selectModel(boards, ocamDegrees(4, 6), {});
  EXPECT_EQ(s.folds, 0);
  EXPECT_EQ(s.chosen, 0u);
  EXPECT_EQ(s.scores[0].candidate.degree, 4);
  EXPECT_NE(s.reason.find("too few"), std::string::npos) << s.reason;
  EXPECT_GT(s.scores[0].train_rms_px, 0.0);
}

}  // namespace
}  // namespace ovo::calib
