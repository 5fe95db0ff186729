// Fuzz targets for the trajectory files (ground truth, `ovo eval` inputs): TUM (with format
// detection), KITTI with or without times, the EuRoC ground-truth csv, and the gyro-bias csv.
#include "io/trajectory_io.hpp"
#include "tests/fuzz/fuzz_target.hpp"

OVO_FUZZ_TARGET(trajectory_tum) {
  const auto file = ovo::fuzz::writeScratch("traj.txt", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readTum(file); });
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readTrajectory(file); });
}

OVO_FUZZ_TARGET(trajectory_kitti) {
  const auto file = ovo::fuzz::writeScratch("poses.txt", input);
  ovo::fuzz::expectOnlyOvoErrors([&] {
    bool has_time = false;
    (void)ovo::io::readKitti(file, &has_time);
  });
}

OVO_FUZZ_TARGET(trajectory_euroc) {
  const auto file = ovo::fuzz::writeScratch("data.csv", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readEurocGroundtruthCsv(file); });
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readTrajectory(file); });
}

OVO_FUZZ_TARGET(gyro_bias_csv) {
  const auto file = ovo::fuzz::writeScratch("truth_bias.csv", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readGyroBiasCsv(file); });
}
