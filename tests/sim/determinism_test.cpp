#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/config.hpp"
#include "io/dataset.hpp"
#include "sim/lidar.hpp"
#include "sim/simulation.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

Scenario shortScenario(std::uint64_t seed) {
  Scenario s = test::defaultScenario();
  s.seed = seed;
  s.frames = 4;
  s.nuisance.people = 1;
  return s;
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

TEST(Determinism, SameSeedGivesIdenticalSensorData) {
  const Simulation a(shortScenario(9)), b(shortScenario(9));
  EXPECT_TRUE(sameImage(a.renderFrame(3), b.renderFrame(3)));
  const auto imu_a = a.imu(), imu_b = b.imu();
  ASSERT_EQ(imu_a.size(), imu_b.size());
  for (std::size_t k = 0; k < imu_a.size(); ++k) {
    ASSERT_EQ(imu_a[k].gyro_radps, imu_b[k].gyro_radps);
    ASSERT_EQ(imu_a[k].accel_mps2, imu_b[k].accel_mps2);
  }
  const auto la = a.lidar(), lb = b.lidar();
  ASSERT_EQ(la.size(), lb.size());
  for (std::size_t k = 0; k < la.size(); ++k)
    for (std::size_t i = 0; i < la[k].ranges_m.size(); ++i)
      ASSERT_TRUE(
          la[k].ranges_m[i] == lb[k].ranges_m[i] ||
          (la[k].ranges_m[i] != la[k].ranges_m[i] && lb[k].ranges_m[i] != lb[k].ranges_m[i]));
}

TEST(Determinism, AnotherSeedGivesAnotherTextureNoiseAndMotion) {
  Scenario s1 = shortScenario(9), s2 = shortScenario(10);
  s1.nuisance.image_noise = s2.nuisance.image_noise = false;
  const Simulation a(s1), b(s2);
  const cv::Mat ia = a.renderFrame(0), ib = b.renderFrame(0);
  EXPECT_GT(cv::norm(ia, ib, cv::NORM_L1) / ia.total(),
            5.0);  // a different texture, not just noise
  EXPECT_NE(a.imu()[10].gyro_radps, b.imu()[10].gyro_radps);
  EXPECT_NE(a.trajectory().T_W_B(0.0).translation(), b.trajectory().T_W_B(0.0).translation());
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Determinism, SimulateCommandWritesTheSameBytesForTheSameSeed) {
  const char* bin = std::getenv("OVO_BIN");
  if (!bin || !std::filesystem::exists(bin)) GTEST_SKIP() << "the ovo binary is not built";
  // Not under tempDir(): runOvo() empties that folder on every call.
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ovo_sim_determinism_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const std::string common = "simulate --config " +
                             ::ovo::test::sourcePath("configs/sim/vineyard_row.yaml").string() +
                             " --frames 3 --set nuisance.people=1";
  std::string err;
  ASSERT_EQ(::ovo::test::runOvo(common + " --out " + (dir / "a").string(), nullptr, &err), 0)
      << err;
  ASSERT_EQ(::ovo::test::runOvo(common + " --out " + (dir / "b").string(), nullptr, &err), 0)
      << err;
  ASSERT_EQ(::ovo::test::runOvo(common + " --seed 5 --out " + (dir / "c").string(), nullptr, &err),
            0)
      << err;
  int files = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir / "a")) {
    if (!e.is_regular_file()) continue;
    const auto rel = std::filesystem::relative(e.path(), dir / "a");
    EXPECT_EQ(slurp(e.path()), slurp(dir / "b" / rel)) << rel;
    ++files;
  }
  EXPECT_GE(files, 10);  // 3 images, data.csv files, calibration, rig, ground truth, sim/*
  // The dataset reader takes what the simulator writes.
  const io::Dataset ds = io::loadDataset(dir / "a");
  EXPECT_EQ(ds.images.size(), 3u);
  EXPECT_EQ(ds.scans.size(), 2u);
  EXPECT_EQ(ds.groundtruth.size(), 3u);
  EXPECT_EQ(ds.imu.size(), 21u);  // 0.1 s at 200 Hz, both ends
  EXPECT_FALSE(ds.true_gyro_bias.empty());
  ASSERT_TRUE(ds.camera.has_value());
  EXPECT_EQ(camera::modelName(*ds.camera), "ocam");
  ASSERT_TRUE(ds.rig.camera_height_m.has_value());
  EXPECT_NEAR(*ds.rig.camera_height_m, 1.0, 1e-9);
  EXPECT_TRUE(ds.rig.T_B_C.isApprox(
      cameraMountTransform(
          readScenario(Config::load(::ovo::test::sourcePath("configs/sim/vineyard_row.yaml")))
              .camera.mount),
      1e-12));
  const auto first = std::filesystem::path("cam0/data/1000000000.png");
  EXPECT_NE(slurp(dir / "a" / first), slurp(dir / "c" / first));
  // A failed run leaves nothing behind.
  EXPECT_NE(::ovo::test::runOvo(common + " --set world.bogus=1 --out " + (dir / "d").string()), 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "d"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ovo::sim
