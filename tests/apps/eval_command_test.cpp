// `ovo eval` end to end: runs the built command and parses the JSON it prints.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "tests/test_support.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

std::string ovoBinary() {
  const char* bin = std::getenv("OVO_BIN");
  return bin ? bin : std::string(OVO_BINARY_DIR) + "/ovo";
}

#define OVO_REQUIRE_BINARY()                                                        \
  do {                                                                              \
    if (!fs::exists(ovoBinary())) GTEST_SKIP() << "ovo not built: " << ovoBinary(); \
  } while (0)

std::string quoted(const fs::path& p) {
  std::string q = "'";
  q.append(p.string()).push_back('\'');
  return q;
}

TEST(EvalCommand, KittiOrbMatchesEvoApeAndRpe) {
  OVO_REQUIRE_BINARY();
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  std::string out, err;
  const int code = runOvo("eval --gt " + quoted(sharedData("traj-eval-evo/KITTI_00_gt.txt")) +
                              " --est " + quoted(sharedData("traj-eval-evo/KITTI_00_ORB.txt")) +
                              " --format kitti --align se3 --rpe-delta 10 --rpe-unit m",
                          &out, &err);
  ASSERT_EQ(code, 0) << err;
  const auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j["pairs"].get<int>(), 4541);
  EXPECT_EQ(j["align"].get<std::string>(), "se3");
  EXPECT_DOUBLE_EQ(j["scale"].get<double>(), 1.0);
  // evo_ape kitti KITTI_00_gt.txt KITTI_00_ORB.txt -a (MANIFEST.md of traj-eval-evo).
  EXPECT_NEAR(j["ate"]["rmse"].get<double>(), 1.3034497145650266, 1e-6);
  EXPECT_NEAR(j["ate"]["mean"].get<double>(), 1.1569971285389768, 1e-6);
  EXPECT_NEAR(j["ate"]["median"].get<double>(), 1.065624769555848, 1e-6);
  EXPECT_NEAR(j["ate"]["max"].get<double>(), 3.587949120678954, 1e-6);
  for (const char* key : {"std", "min"}) EXPECT_TRUE(j["ate"].contains(key)) << key;
  // evo_rpe kitti KITTI_00_gt.txt KITTI_00_ORB.txt -d 10 -u m.
  const auto& rpe = j["rpe"];
  EXPECT_DOUBLE_EQ(rpe["delta"].get<double>(), 10.0);
  EXPECT_EQ(rpe["unit"].get<std::string>(), "m");
  EXPECT_EQ(rpe["pairs"].get<int>(), 353);
  EXPECT_NEAR(rpe["trans"]["rmse"].get<double>(), 0.22626134329310163, 1e-6);
  EXPECT_NEAR(rpe["trans"]["mean"].get<double>(), 0.16901737200653275, 1e-6);
  for (const char* key : {"rmse", "mean", "median", "max"})
    EXPECT_TRUE(rpe["rot_deg"].contains(key)) << key;
}

// Issue 59: several estimates in one call, KITTI's segment errors for each, and their drift
// against the distance driven in one SVG.
TEST(EvalCommand, SeveralEstimatesWithSegmentErrorsAndOneDriftPlot) {
  OVO_REQUIRE_BINARY();
  OVO_REQUIRE_DATA("traj-eval-evo/KITTI_00_gt.txt");
  const fs::path dir = tempDir();
  const std::string base = "eval --format kitti --gt " +
                           quoted(sharedData("traj-eval-evo/KITTI_00_gt.txt")) + " --est " +
                           quoted(sharedData("traj-eval-evo/KITTI_00_ORB.txt")) + " --est " +
                           quoted(sharedData("traj-eval-evo/KITTI_00_SPTAM.txt"));
  const fs::path svg = dir / "drift.svg";
  std::string out, err;
  ASSERT_EQ(runOvo(base + " --labels orb,sptam --drift-plot " + quoted(svg), &out, &err), 0)
      << err;
  const auto j = nlohmann::json::parse(out);
  ASSERT_EQ(j["estimates"].size(), 2u);
  EXPECT_NEAR(j["estimates"][0]["ate"]["rmse"].get<double>(), 1.3034497145650266, 1e-6);
  EXPECT_NE(j["estimates"][1]["est"].get<std::string>().find("SPTAM"), std::string::npos);
  for (const auto& e : j["estimates"]) {
    ASSERT_EQ(e["segments"].size(), 5u);  // 10, 25, 50, 100 and 200 m
    EXPECT_EQ(e["segments"][4]["length_m"].get<double>(), 200.0);
    EXPECT_GT(e["segments"][4]["trans_pct"].get<double>(), 0.0);
  }
  std::ifstream in(svg);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  EXPECT_EQ(text.rfind("<?xml", 0), 0u);
  for (const char* s : {">orb<", ">sptam<", "distance driven [m]", "Heading error",
                        "Scale error over the last 25 m"})
    EXPECT_NE(text.find(s), std::string::npos) << s;
  EXPECT_EQ(text.find("nan"), std::string::npos);

  // One estimate: the JSON object as before (no "estimates"), now with its segments.
  ASSERT_EQ(runOvo("eval --format kitti --gt " +
                       quoted(sharedData("traj-eval-evo/KITTI_00_gt.txt")) + " --est " +
                       quoted(sharedData("traj-eval-evo/KITTI_00_ORB.txt")),
                   &out, &err),
            0)
      << err;
  const auto one = nlohmann::json::parse(out);
  EXPECT_FALSE(one.contains("estimates"));
  EXPECT_EQ(one["segments"].size(), 5u);

  // Wrong uses name the option.
  EXPECT_EQ(runOvo(base + " --labels orb", &out, &err), 2);
  EXPECT_NE(err.find("--labels"), std::string::npos) << err;
  EXPECT_EQ(runOvo(base + " --plot " + quoted(dir / "p.svg"), &out, &err), 2);
  EXPECT_NE(err.find("--plot"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "p.svg"));
}

TEST(EvalCommand, TumAndEurocFilesWithAutoDetectionAndSim3) {
  OVO_REQUIRE_BINARY();
  OVO_REQUIRE_DATA("traj-eval-evo/V102_groundtruth.csv");
  std::string out, err;
  ASSERT_EQ(runOvo("eval --gt " + quoted(sharedData("traj-eval-evo/V102_groundtruth.csv")) +
                       " --est " + quoted(sharedData("traj-eval-evo/V102.txt")) + " --align sim3",
                   &out, &err),
            0)
      << err;
  const auto sim3 = nlohmann::json::parse(out);
  EXPECT_FALSE(sim3.contains("rpe"));  // only when asked
  EXPECT_EQ(sim3["align"].get<std::string>(), "sim3");
  EXPECT_GT(sim3["pairs"].get<int>(), 700);
  ASSERT_EQ(runOvo("eval --format euroc --gt " +
                       quoted(sharedData("traj-eval-evo/V102_groundtruth.csv")) + " --est " +
                       quoted(sharedData("traj-eval-evo/V102.txt")),
                   &out, &err),
            0)
      << err;
  const auto se3 = nlohmann::json::parse(out);
  EXPECT_EQ(se3["pairs"], sim3["pairs"]);
  EXPECT_LE(sim3["ate"]["rmse"].get<double>(), se3["ate"]["rmse"].get<double>());
  EXPECT_NE(sim3["scale"].get<double>(), 1.0);
}

TEST(EvalCommand, BadFilesExitNonZeroNamingTheFile) {
  OVO_REQUIRE_BINARY();
  // runOvo() empties tempDir() for its own output: the inputs go beside it.
  const fs::path dir = tempDir().parent_path() / "EvalCommand.inputs";
  fs::create_directories(dir);
  {
    std::ofstream(dir / "gt.txt")
        << "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n2 2 1 0 0 0 0 1\n3 0 2 1 0 0 0 1\n";
    std::ofstream(dir / "bad.txt") << "0 0 0 0 0 0 0 1\n1 1 0 nan 0 0 0 1\n";
    std::ofstream(dir / "far.txt") << "100 0 0 0 0 0 0 1\n";
  }
  std::string out, err;
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "missing.txt"),
                   &out, &err),
            2);
  EXPECT_NE(err.find("missing.txt"), std::string::npos) << err;
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "bad.txt"),
                   &out, &err),
            2);
  EXPECT_NE(err.find("bad.txt:2:"), std::string::npos) << err;
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "far.txt"),
                   &out, &err),
            2);
  EXPECT_NE(err.find("nothing to compare"), std::string::npos) << err;
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "gt.txt") +
                       " --align affine",
                   &out, &err),
            2);
  EXPECT_NE(err.find("--align"), std::string::npos) << err;
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "gt.txt") +
                       " --rpe-delta 0",
                   &out, &err),
            2);
  EXPECT_NE(err.find("--rpe-delta"), std::string::npos) << err;
  // 1e10 s overflowed into a false "no pose within 10000000000 s".
  EXPECT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "gt.txt") +
                       " --max-diff 1e10",
                   &out, &err),
            2);
  EXPECT_NE(err.find("--max-diff: expected a time in [0, 3600] s"), std::string::npos) << err;
  // A trajectory compared with itself: zero error.
  ASSERT_EQ(runOvo("eval --gt " + quoted(dir / "gt.txt") + " --est " + quoted(dir / "gt.txt") +
                       " --rpe-delta 1 --rpe-unit f",
                   &out, &err),
            0)
      << err;
  const auto j = nlohmann::json::parse(out);
  EXPECT_NEAR(j["ate"]["rmse"].get<double>(), 0.0, 1e-12);
  EXPECT_EQ(j["rpe"]["pairs"].get<int>(), 3);
  EXPECT_NEAR(j["rpe"]["trans"]["max"].get<double>(), 0.0, 1e-12);
}

}  // namespace
}  // namespace ovo::test
