// Trajectory files: round trips, format detection, the real formats of the shared data, and a
// clear error (file:line: what was expected) for every kind of bad input.
#include "io/trajectory_io.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "common/error.hpp"
#include "io/text_reader.hpp"
#include "tests/test_support.hpp"

namespace ovo::io {
namespace {

namespace fs = std::filesystem;

using test::errorOf;

Trajectory sampleTrajectory() {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.t_ns = 1'403'715'273'262'142'976LL + i * 50'000'001LL;
    p.T_W_B.linear() =
        Eigen::AngleAxisd(0.3 * i + 0.1, Vec3(1, -2, 0.5 * i).normalized()).toRotationMatrix();
    p.T_W_B.translation() = Vec3(0.1 * i, -1.0 / 3.0, 1e-7 * i);
    t.push_back(p);
  }
  return t;
}

void expectSamePoses(const Trajectory& a, const Trajectory& b, bool same_time, double tol) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (same_time) {
      EXPECT_EQ(a[i].t_ns, b[i].t_ns);
    }
    EXPECT_LE((a[i].T_W_B.matrix() - b[i].T_W_B.matrix()).cwiseAbs().maxCoeff(), tol) << i;
  }
}

TEST(TrajectoryIo, TumRoundTripKeepsNanosecondsAndPoses) {
  const fs::path file = test::tempDir() / "traj.txt";
  const Trajectory t = sampleTrajectory();
  writeTum(file, t);
  const Trajectory back = readTum(file);
  expectSamePoses(t, back, true, 1e-15);
  EXPECT_EQ(readTrajectory(file).format, TrajectoryFormat::kTum);
}

TEST(TrajectoryIo, KittiRoundTripWithAndWithoutTime) {
  const fs::path dir = test::tempDir();
  const Trajectory t = sampleTrajectory();
  writeKitti(dir / "with.txt", t, true);
  writeKitti(dir / "without.txt", t, false);
  bool has_time = false;
  expectSamePoses(t, readKitti(dir / "with.txt", &has_time), true, 0.0);
  EXPECT_TRUE(has_time);
  const Trajectory no_time = readKitti(dir / "without.txt", &has_time);
  EXPECT_FALSE(has_time);
  expectSamePoses(t, no_time, false, 0.0);
  EXPECT_EQ(no_time[3].t_ns, 3'000'000'000LL);  // index seconds
  const auto detected = readTrajectory(dir / "without.txt");
  EXPECT_EQ(detected.format, TrajectoryFormat::kKitti);
  EXPECT_FALSE(detected.has_time);
}

TEST(TrajectoryIo, WriteReplacesAtomicallyAndFailsCleanly) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "t.txt", "old content\n");
  writeTum(dir / "t.txt", sampleTrajectory());
  EXPECT_EQ(readTum(dir / "t.txt").size(), 5u);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left behind
  const std::string err =
      errorOf([&] { writeTum(dir / "no_such_dir" / "t.txt", sampleTrajectory()); });
  EXPECT_CONTAINS(err, "no_such_dir/t.txt");
}

TEST(TrajectoryIo, ExactTimeParsing) {
  const fs::path file = test::tempDir() / "t.txt";
  test::writeTextFile(file,
                      "# comment\n"
                      "1305031102.160407 0 0 0 0 0 0 1\n"
                      "1.403715529112143517e+09 0 0 0 0 0 0 1\n"
                      "1403715529.2121429 0 0 0 0 0 0 2\n");
  const Trajectory t = readTum(file);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].t_ns, 1305031102160407000LL);
  EXPECT_NEAR(static_cast<double>(t[1].t_ns - 1403715529112143517LL), 0.0, 2.0);
  EXPECT_EQ(t[2].t_ns, 1403715529212142900LL);
  EXPECT_NEAR(Quat(t[2].T_W_B.linear()).w(), 1.0, 1e-15);  // normalised quaternion
  EXPECT_EQ(formatSeconds(-1'500'000'000LL), "-1.500000000");
  EXPECT_EQ(formatSeconds(12'000'000'001LL), "12.000000001");
}

// A stamp of 9.3e9 s overflowed int64 nanoseconds (signed overflow, undefined; found by the
// trajectory_tum fuzz target under UBSan): now an error naming the line, as 9.3e+09 already was.
TEST(TrajectoryIo, TimesBeyondInt64NanosecondsAreAnError) {
  const fs::path file = test::tempDir() / "t.txt";
  test::writeTextFile(file, "9000000000.5 0 0 0 0 0 0 1\n9305031098.665 0 0 0 0 0 0 1\n");
  EXPECT_CONTAINS(test::errorOf([&] { readTum(file); }),
                  "t.txt:2: expected a time in seconds of at most 9000000000");
  test::writeTextFile(file, "9000000000.5 0 0 0 0 0 0 1\n");
  EXPECT_EQ(readTum(file).front().t_ns, 9'000'000'000'500'000'000LL);
  test::writeTextFile(file, "9.3e9 0 0 0 0 0 0 1\n");
  EXPECT_CONTAINS(test::errorOf([&] { readTum(file); }), "t.txt:1: expected a finite time");
}

TEST(TrajectoryIo, RealFilesOfTheSharedData) {
  OVO_REQUIRE_DATA("traj-eval-evo/V102_groundtruth.csv");
  const auto euroc = readTrajectory(test::sharedData("traj-eval-evo/V102_groundtruth.csv"));
  EXPECT_EQ(euroc.format, TrajectoryFormat::kEurocCsv);
  ASSERT_EQ(euroc.poses.size(), 16702u);
  // First row: 1403715524907143168, p 0.515356 1.996773 0.971104, q (w x y z) 0.161996 0.789985
  // -0.205376 0.554528.
  EXPECT_EQ(euroc.poses[0].t_ns, 1403715524907143168LL);
  EXPECT_NEAR(euroc.poses[0].T_W_B.translation().y(), 1.996773, 1e-12);
  const Quat q(euroc.poses[0].T_W_B.linear());
  const Quat expected = Quat(0.161996, 0.789985, -0.205376, 0.554528).normalized();
  EXPECT_NEAR(q.angularDistance(expected), 0.0, 1e-9);

  const auto kitti =
      readTrajectory(test::sharedData("kitti07-first160/poses_07_time_prefixed.txt"));
  EXPECT_EQ(kitti.format, TrajectoryFormat::kKitti);
  EXPECT_TRUE(kitti.has_time);
  ASSERT_EQ(kitti.poses.size(), 1101u);
  EXPECT_EQ(kitti.poses[1].t_ns, 103875200);
  EXPECT_NEAR(kitti.poses[1].T_W_B.translation().z(), 0.09154274, 1e-12);

  const auto tum = readTrajectory(test::sharedData("traj-eval-evo/fr2_desk_groundtruth.txt"));
  EXPECT_EQ(tum.format, TrajectoryFormat::kTum);
  EXPECT_EQ(tum.poses.size(), 20957u);  // one repeated stamp is kept, as evo does
}

struct BadCase {
  const char* name;
  TrajectoryFormat format;
  const char* text;
  const char* expected;  // part of the message after "file:line: "
  int line;
};

TEST(TrajectoryIo, BadInputNamesFileLineAndWhatWasExpected) {
  const BadCase cases[] = {
      {"tum_columns", TrajectoryFormat::kTum, "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n",
       "expected 8 values", 2},
      {"tum_nan", TrajectoryFormat::kTum, "# x\n0 0 nan 0 0 0 0 1\n", "finite number for ty", 2},
      {"tum_inf", TrajectoryFormat::kTum, "0 0 0 0 0 0 0 inf\n", "finite number for qw", 1},
      {"tum_text", TrajectoryFormat::kTum, "0 0 0 x 0 0 0 1\n", "expected a number for tz", 1},
      {"tum_order", TrajectoryFormat::kTum, "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n",
       "must not decrease", 2},
      {"tum_zero_q", TrajectoryFormat::kTum, "0 0 0 0 0 0 0 0\n", "zero length", 1},
      {"tum_time", TrajectoryFormat::kTum, "t 0 0 0 0 0 0 1\n", "time in seconds", 1},
      {"kitti_columns", TrajectoryFormat::kKitti, "1 0 0 0 0 1 0 0 0 0 1\n", "expected 12 values",
       1},
      {"kitti_mixed", TrajectoryFormat::kKitti,
       "1 0 0 0 0 1 0 0 0 0 1 0\n0 1 0 0 0 0 1 0 0 0 0 1 0\n", "like the first row", 2},
      {"kitti_nan", TrajectoryFormat::kKitti, "1 0 0 0 0 1 0 0 0 0 1 nan\n", "element (2, 3)", 1},
      {"kitti_far", TrajectoryFormat::kKitti, "1 0 0 0 0 1 0 -2e9 0 0 1 0\n",
       "beyond any trajectory", 1},
      // A rotation scaled, zeroed, mirrored or with one element corrupt gave NaN RPE in eval.
      {"kitti_scaled_rotation", TrajectoryFormat::kKitti,
       "1 0 0 0 0 1 0 0 0 0 1 0\n"
       "2 0 0 0 0 2 0 0 0 0 2 0\n",
       "the 3x3 part is not a rotation", 2},
      {"kitti_zero_rotation", TrajectoryFormat::kKitti, "0 0 0 0 0 0 0 0 0 0 0 0\n",
       "the 3x3 part is not a rotation", 1},
      {"kitti_mirror", TrajectoryFormat::kKitti, "-1 0 0 0 0 1 0 0 0 0 1 0\n", "det -1", 1},
      {"kitti_huge_element", TrajectoryFormat::kKitti, "5 1e300 0 0 0 0 1 0 0 0 0 1 0\n",
       "expected an orthonormal matrix", 1},
      {"tum_far", TrajectoryFormat::kTum, "0 0 0 0 0 0 0 1\n1 0 0 1e300 0 0 0 1\n",
       "expected coordinates within 1e+09 m", 2},
      {"euroc_columns", TrajectoryFormat::kEurocCsv,
       "#t,px,py,pz,qw,qx,qy,qz\n1,0,0,0,1,0,0,0\n2,0,0,0,1,0,0\n", "at least 8 columns", 3},
      {"euroc_mixed", TrajectoryFormat::kEurocCsv, "1,0,0,0,1,0,0,0,5\n2,0,0,0,1,0,0,0\n",
       "9 columns like the first row", 2},
      {"euroc_order", TrajectoryFormat::kEurocCsv, "5,0,0,0,1,0,0,0\n4,0,0,0,1,0,0,0\n",
       "must not decrease", 2},
      {"euroc_stamp", TrajectoryFormat::kEurocCsv, "1.5,0,0,0,1,0,0,0\n", "integer", 1},
      {"auto_unknown", TrajectoryFormat::kAuto, "1 2 3\n", "cannot tell the trajectory format", 1},
  };
  const fs::path dir = test::tempDir();
  for (const auto& c : cases) {
    const fs::path file = dir / (std::string(c.name) + ".txt");
    test::writeTextFile(file, c.text);
    const std::string err = errorOf([&] { readTrajectory(file, c.format); });
    EXPECT_CONTAINS(err, file.string() + ":" + std::to_string(c.line) + ": ");
    EXPECT_CONTAINS(err, c.expected);
  }
}

TEST(TrajectoryIo, EmptyOrMissingFilesAreClearErrors) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "empty.txt", "");
  test::writeTextFile(dir / "comments.txt", "# only a comment\n\n");
  for (auto format : {TrajectoryFormat::kTum, TrajectoryFormat::kKitti, TrajectoryFormat::kEurocCsv,
                      TrajectoryFormat::kAuto}) {
    EXPECT_CONTAINS(errorOf([&] { readTrajectory(dir / "empty.txt", format); }), "no poses found");
    EXPECT_CONTAINS(errorOf([&] { readTrajectory(dir / "comments.txt", format); }), "comments.txt");
    EXPECT_CONTAINS(errorOf([&] { readTrajectory(dir / "missing.txt", format); }),
                    (dir / "missing.txt").string() + ": cannot open");
  }
  EXPECT_CONTAINS(errorOf([&] { readTrajectory(dir, TrajectoryFormat::kTum); }), "is a folder");
  EXPECT_CONTAINS(errorOf([] { parseTrajectoryFormat("csv"); }), "expected tum, kitti, euroc");
}

}  // namespace
}  // namespace ovo::io
