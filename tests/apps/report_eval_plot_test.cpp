// `ovo eval --plot OUT.svg`: a standalone SVG with the top view and the errors over time of any
// two trajectories; KITTI's camera-frame world is seen from above (x-z plane).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/apps/online_test_data.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

TEST(EvalPlot, WritesAStandaloneSvgWithTopViewAndErrors) {
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  if (!fs::exists(ovoBinaryPath())) GTEST_SKIP() << "ovo not built";
  const fs::path dir = tempDir();
  const fs::path svg = dir / "plot.svg";
  std::string out;
  const int code = runShell("'" + ovoBinaryPath().string() + "' eval --gt '" +
                                sharedData("traj-eval-evo/KITTI_00_gt.txt").string() + "' --est '" +
                                sharedData("traj-eval-evo/KITTI_00_ORB.txt").string() +
                                "' --format kitti --plot '" + svg.string() + "'",
                            dir, &out);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"ate\""), std::string::npos);  // the JSON is still printed
  std::ifstream in(svg);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  EXPECT_EQ(text.rfind("<?xml", 0), 0u);
  std::size_t svgs = 0;
  for (auto p = text.find("<svg"); p != std::string::npos; p = text.find("<svg", p + 1)) ++svgs;
  EXPECT_EQ(svgs, 4u);                                 // the document and its three plots
  EXPECT_NE(text.find(">z [m]<"), std::string::npos);  // KITTI world: top view is x-z
  EXPECT_NE(text.find("pose index"), std::string::npos);
  EXPECT_EQ(text.find("nan"), std::string::npos);
  EXPECT_EQ(text.find("inf\""), std::string::npos);

  const int bad = runShell("'" + ovoBinaryPath().string() + "' eval --gt '" +
                               sharedData("traj-eval-evo/KITTI_00_gt.txt").string() + "' --est '" +
                               sharedData("traj-eval-evo/KITTI_00_ORB.txt").string() +
                               "' --format kitti --plot /nonexistent-dir/p.svg",
                           dir, &out);
  EXPECT_EQ(bad, 2);
  EXPECT_NE(out.find("/nonexistent-dir/p.svg"), std::string::npos) << out;

  // A step that fails after the alignment (an RPE delta longer than the run) leaves no plot.
  const std::string kitti = "'" + ovoBinaryPath().string() + "' eval --format kitti --est '" +
                            sharedData("traj-eval-evo/KITTI_00_ORB.txt").string() + "' ";
  const fs::path late = dir / "late.svg";
  EXPECT_EQ(runShell(kitti + "--gt '" + sharedData("traj-eval-evo/KITTI_00_gt.txt").string() +
                         "' --rpe-delta 1e9 --plot '" + late.string() + "'",
                     dir, &out),
            2);
  EXPECT_FALSE(fs::exists(late)) << out;
  // The plot may not overwrite an input (it replaced the ground truth with SVG, exit 0).
  const fs::path gt_copy = dir / "gt.txt";
  fs::copy_file(sharedData("traj-eval-evo/KITTI_00_gt.txt"), gt_copy);
  const auto size = fs::file_size(gt_copy);
  EXPECT_EQ(runShell(kitti + "--gt '" + gt_copy.string() + "' --plot '" + gt_copy.string() + "'",
                     dir, &out),
            2);
  EXPECT_NE(out.find("is one of the input trajectories"), std::string::npos) << out;
  EXPECT_EQ(fs::file_size(gt_copy), size);
}

}  // namespace
}  // namespace ovo::test
