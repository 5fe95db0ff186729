// Dataset folders: the real EuRoC and KITTI folders load as they are; a small synthetic ovo
// folder loads every stream; each kind of bad input gives an error naming the file (and line).
#include "io/dataset.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/error.hpp"
#include "tests/test_support.hpp"

namespace ovo::io {
namespace {

namespace fs = std::filesystem;

using test::errorOf;

TEST(Dataset, EurocMicroLoadsAsItIs) {
  OVO_REQUIRE_DATA("euroc-v101-micro/mav0");
  const Dataset ds = loadDataset(test::sharedData("euroc-v101-micro"));
  EXPECT_EQ(ds.kind, "ovo");
  ASSERT_EQ(ds.images.size(), 95u);
  EXPECT_EQ(ds.images.front().t_ns, 1403715273262142976LL);
  ASSERT_TRUE(ds.camera);
  EXPECT_EQ(camera::modelName(*ds.camera), "pinhole_radtan");
  EXPECT_EQ(camera::width(*ds.camera), 752);
  EXPECT_EQ(camera::height(*ds.camera), 480);
  // T_B_C from mav0/cam0/sensor.yaml T_BS (row 0: 0.0148655429818, -0.999880929698, ...).
  EXPECT_FALSE(ds.rig.has_rig_file);
  EXPECT_NEAR(ds.rig.T_B_C.matrix()(0, 1), -0.999880929698, 1e-12);
  EXPECT_NEAR(ds.rig.T_B_C.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(ds.rig.camera_rate_hz, 20.0, 0.01);
  ASSERT_EQ(ds.imu.size(), 29120u);
  EXPECT_NEAR(ds.rig.gyro_rate_hz, 200.0, 0.1);
  EXPECT_NEAR(ds.imu.front().gyro_radps.z(), 0.07749261878854824, 1e-15);
  EXPECT_NEAR(ds.imu.front().accel_mps2.x(), 9.0874956666666655, 1e-12);
  // Ground truth from the TUM file in state_groundtruth_estimate0/.
  ASSERT_EQ(ds.groundtruth.size(), 28712u);
  EXPECT_EQ(ds.groundtruth.front().t_ns, 1403715274302140000LL);
  EXPECT_TRUE(ds.scans.empty());
  const cv::Mat image = loadImageGrey(ds.images.front());
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(image.cols, 752);
  EXPECT_EQ(image.rows, 480);
}

TEST(Dataset, Kitti07First160LoadsAsItIs) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0");
  const Dataset ds = loadDataset(test::sharedData("kitti07-first160"));
  EXPECT_EQ(ds.kind, "kitti");
  // times.txt has all 1101 stamps; only the 160 frames present are used.
  ASSERT_EQ(ds.images.size(), 160u);
  EXPECT_EQ(ds.images[0].t_ns, 0);
  EXPECT_EQ(ds.images[1].t_ns, 103875200);
  EXPECT_EQ(ds.images[159].path.filename(), "000159.png");
  ASSERT_TRUE(ds.camera);
  EXPECT_EQ(camera::modelName(*ds.camera), "pinhole_radtan");
  EXPECT_EQ(camera::width(*ds.camera), 1226);
  EXPECT_EQ(camera::height(*ds.camera), 370);
  // P0: fx = fy = 707.0912, cx 601.8873, cy 183.1104: the principal point's bearing is +z.
  const auto b = camera::unproject(*ds.camera, Vec2(601.8873, 183.1104));
  ASSERT_TRUE(b);
  EXPECT_NEAR((*b - Vec3::UnitZ()).norm(), 0.0, 1e-12);
  const auto px = camera::project(*ds.camera, Vec3(1.0, 0.0, 707.0912));
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->x(), 602.8873, 1e-9);
  // The KITTI rig: the camera looks along body x, its y axis points down (-z_B).
  EXPECT_TRUE((ds.rig.T_B_C.linear() * Vec3::UnitZ()).isApprox(Vec3::UnitX()));
  EXPECT_TRUE((ds.rig.T_B_C.linear() * Vec3::UnitY()).isApprox(-Vec3::UnitZ()));
  ASSERT_TRUE(ds.rig.camera_height_m);
  EXPECT_DOUBLE_EQ(*ds.rig.camera_height_m, 1.65);
  EXPECT_NEAR(ds.rig.camera_rate_hz, 9.6, 0.3);
  // Ground truth: 1101 rows with a time column; row 1 at 0.1038752 s, camera z (forward)
  // 0.09154274 m, which is body/world x (forward) after the change to the z-up world.
  ASSERT_EQ(ds.groundtruth.size(), 1101u);
  EXPECT_EQ(ds.groundtruth[1].t_ns, ds.images[1].t_ns);
  EXPECT_NEAR(ds.groundtruth[1].T_W_B.translation().x(), 0.09154274, 1e-12);
  EXPECT_TRUE(ds.groundtruth[0].T_W_B.isApprox(SE3::Identity(), 1e-6));
  const cv::Mat image = loadImageGrey(ds.images[42]);
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(image.size(), cv::Size(1226, 370));
}

// `ovo run --gt FILE` on a KITTI folder: a KITTI poses file, with or without the time column,
// is turned into T_W_B as the folder's own is; a TUM file (already T_W_B) is taken as it is.
TEST(Dataset, KittiGroundTruthGivenAsAFileMatchesTheFoldersOwn) {
  OVO_REQUIRE_DATA("kitti07-first160/poses_07_time_prefixed.txt");
  const Dataset ds = loadDataset(test::sharedData("kitti07-first160"));
  const fs::path timed = test::sharedData("kitti07-first160/poses_07_time_prefixed.txt");
  const fs::path dir = test::tempDir();
  // The same rows without the time column (the official KITTI layout), first 200 only.
  std::ifstream in(timed);
  std::string line, untimed;
  for (int i = 0; i < 200 && std::getline(in, line); ++i)
    untimed += line.substr(line.find(' ') + 1) + "\n";
  test::writeTextFile(dir / "07.txt", untimed);
  for (const fs::path& file : {timed, dir / "07.txt"}) {
    SCOPED_TRACE(file.string());
    const Trajectory gt = readGroundtruthFor(ds, file);
    ASSERT_GE(gt.size(), 200u);
    for (std::size_t i : {1u, 80u, 159u}) {
      EXPECT_EQ(gt[i].t_ns, ds.groundtruth[i].t_ns);
      EXPECT_TRUE(gt[i].T_W_B.isApprox(ds.groundtruth[i].T_W_B, 1e-12));
    }
  }
  // Frame 60, after the first left turn (about 95 degrees): the body's x axis has turned to +y,
  // a positive yaw about the z-up world's z.
  const Vec3 x_W = ds.groundtruth[60].T_W_B.linear() * Vec3::UnitX();
  EXPECT_NEAR(std::atan2(x_W.y(), x_W.x()), 95.0 * M_PI / 180.0, 0.05);
  EXPECT_LT(std::abs(x_W.z()), 0.1);
  // A TUM file is T_W_B already.
  test::writeTextFile(dir / "gt.txt", "0.0 1 2 3 0 0 0 1\n0.1 1 2 4 0 0 0 1\n");
  const Trajectory tum = readGroundtruthFor(ds, dir / "gt.txt");
  ASSERT_EQ(tum.size(), 2u);
  EXPECT_TRUE(tum[1].T_W_B.translation().isApprox(Vec3(1, 2, 4)));
  // More untimed poses than times.txt has stamps: an error naming both files.
  std::string many;
  for (int i = 0; i < 1102; ++i) many += "1 0 0 0 0 1 0 0 0 0 1 0\n";
  test::writeTextFile(dir / "long.txt", many);
  const std::string error = errorOf([&] { readGroundtruthFor(ds, dir / "long.txt"); });
  EXPECT_CONTAINS(error, "long.txt: 1102 poses");
  EXPECT_CONTAINS(error, "times.txt has only 1101");
}

// A small complete ovo folder: 3 images, pinhole sensor.yaml, IMU, LiDAR, rig.yaml, ground
// truth and the simulator's true bias.
fs::path writeMiniDataset(const fs::path& root) {
  const cv::Mat image(48, 64, CV_8UC1, cv::Scalar(128));
  fs::create_directories(root / "cam0" / "data");
  std::string list = "#timestamp [ns],filename\n";
  for (int i = 0; i < 3; ++i) {
    const std::string name = std::to_string(1000000000LL + i * 50000000LL) + ".png";
    cv::imwrite((root / "cam0" / "data" / name).string(), image);
    list += std::to_string(1000000000LL + i * 50000000LL) + "," + name + "\n";
  }
  test::writeTextFile(root / "cam0" / "data.csv", list);
  test::writeTextFile(
      root / "cam0" / "sensor.yaml",
      "sensor_type: camera\n"
      "T_BS:\n  cols: 4\n  rows: 4\n  data: [0, 0, 1, 0.1, -1, 0, 0, 0, 0, -1, 0, 0.5, 0, 0, "
      "0, 1]\n"
      "rate_hz: 20\nresolution: [64, 48]\ncamera_model: pinhole\n"
      "intrinsics: [50.0, 50.0, 31.5, 23.5]\n"
      "distortion_model: radial-tangential\ndistortion_coefficients: [0, 0, 0, 0]\n");
  test::writeTextFile(root / "imu0" / "data.csv",
                      "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                      "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
                      "1000000000,0.1,0.2,0.3,0,0,9.81\n1005000000,0.1,0.2,0.3,0,0,9.81\n");
  test::writeTextFile(
      root / "lidar0" / "data.csv",
      "#timestamp [ns],angle_min [rad],angle_increment [rad],range_min [m],range_max [m],"
      "ranges [m]...\n"
      "1000000000,-1.5,0.5,0.1,30,1.0,nan,2.5,40,0.05,inf,3\n"
      "1100000000,-1.5,0.5,0.1,30,1.1,1.2,nan,nan,nan,nan,nan\n");
  test::writeTextFile(root / "rig.yaml",
                      "T_B_C: [0, 0, 1, 0.2, -1, 0, 0, 0, 0, -1, 0, 1.0, 0, 0, 0, 1]\n"
                      "T_B_L: [1, 0, 0, 0.3, 0, 1, 0, 0, 0, 0, 1, 0.6, 0, 0, 0, 1]\n"
                      "camera: {rate_hz: 20.0, pixel_sigma: 0.7, height_m: 1.2}\n"
                      "gyro: {rate_hz: 200.0, noise_density: 2.0e-4, bias_random_walk: 3.0e-5}\n"
                      "lidar: {rate_hz: 10.0, range_sigma_m: 0.03}\n");
  test::writeTextFile(root / "groundtruth.txt",
                      "# t[s] tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.05 0.1 0 0 0 0 0 1\n");
  test::writeTextFile(root / "sim" / "truth_bias.csv",
                      "#timestamp [ns],b_x,b_y,b_z [rad s^-1]\n1000000000,0.001,-0.002,0.003\n");
  return root;
}

TEST(Dataset, MiniOvoFolderLoadsEveryStream) {
  const Dataset ds = loadDataset(writeMiniDataset(test::tempDir() / "ds"));
  EXPECT_EQ(ds.kind, "ovo");
  ASSERT_EQ(ds.images.size(), 3u);
  EXPECT_EQ(ds.images[2].t_ns, 1100000000LL);
  ASSERT_TRUE(ds.camera);
  EXPECT_EQ(camera::width(*ds.camera), 64);
  // rig.yaml wins over sensor.yaml's T_BS.
  EXPECT_TRUE(ds.rig.has_rig_file);
  EXPECT_DOUBLE_EQ(ds.rig.T_B_C.translation().x(), 0.2);
  EXPECT_DOUBLE_EQ(ds.rig.T_B_L.translation().z(), 0.6);
  EXPECT_DOUBLE_EQ(ds.rig.pixel_sigma, 0.7);
  ASSERT_TRUE(ds.rig.camera_height_m);
  EXPECT_DOUBLE_EQ(*ds.rig.camera_height_m, 1.2);
  EXPECT_DOUBLE_EQ(ds.rig.gyro_noise_density, 2.0e-4);
  EXPECT_DOUBLE_EQ(ds.rig.gyro_bias_random_walk, 3.0e-5);
  EXPECT_DOUBLE_EQ(ds.rig.lidar_range_sigma_m, 0.03);
  ASSERT_EQ(ds.imu.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.imu[1].gyro_radps.y(), 0.2);
  ASSERT_EQ(ds.scans.size(), 2u);
  const LidarScan& s = ds.scans[0];
  ASSERT_EQ(s.ranges_m.size(), 7u);
  EXPECT_TRUE(s.valid(0));
  EXPECT_FALSE(s.valid(1));  // nan
  EXPECT_FALSE(s.valid(3));  // beyond range_max
  EXPECT_FALSE(s.valid(4));  // below range_min
  EXPECT_FALSE(s.valid(5));  // inf
  EXPECT_NEAR(s.angle(2), -0.5, 1e-15);
  ASSERT_EQ(ds.groundtruth.size(), 2u);
  EXPECT_EQ(ds.groundtruth[1].t_ns, 1050000000LL);
  ASSERT_EQ(ds.true_gyro_bias.size(), 1u);
  EXPECT_DOUBLE_EQ(ds.true_gyro_bias[0].second.y(), -0.002);
}

TEST(Dataset, WithoutRigFileUsesSensorYamlExtrinsicsAndMeasuredRates) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  fs::remove(root / "rig.yaml");
  const Dataset ds = loadDataset(root);
  EXPECT_FALSE(ds.rig.has_rig_file);
  EXPECT_DOUBLE_EQ(ds.rig.T_B_C.translation().x(), 0.1);
  EXPECT_DOUBLE_EQ(ds.rig.T_B_C.matrix()(1, 0), -1.0);
  EXPECT_NEAR(ds.rig.camera_rate_hz, 20.0, 1e-9);
  EXPECT_NEAR(ds.rig.gyro_rate_hz, 200.0, 1e-9);
  EXPECT_NEAR(ds.rig.lidar_rate_hz, 10.0, 1e-9);
}

// rig.yaml without T_B_C: the camera's sensor.yaml T_BS; without that either, an error (the
// identity it used to take has the camera looking up at the sky: 0 keyframes, exit 0).
TEST(Dataset, RigFileWithoutTBCTakesTheSensorYamlOrIsAnError) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  test::writeTextFile(root / "rig.yaml", "camera: {rate_hz: 20.0, height_m: 1.2}\n");
  const Dataset ds = loadDataset(root);
  EXPECT_TRUE(ds.rig.has_rig_file);
  EXPECT_DOUBLE_EQ(ds.rig.T_B_C.translation().x(), 0.1);  // sensor.yaml's T_BS
  EXPECT_DOUBLE_EQ(ds.rig.T_B_C.matrix()(1, 0), -1.0);
  // An OCamCalib camera has no T_BS.
  OVO_REQUIRE_DATA("romovi-fisheye-calib/calib_results.txt");
  fs::remove(root / "cam0" / "sensor.yaml");
  fs::copy_file(test::sharedData("romovi-fisheye-calib/calib_results.txt"),
                root / "cam0" / "calib_results.txt");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), (root / "rig.yaml").string() + ": no T_B_C");
}

TEST(Dataset, OcamCalibrationInCam0IsUsed) {
  OVO_REQUIRE_DATA("romovi-fisheye-calib/calib_results.txt");
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  fs::copy_file(test::sharedData("romovi-fisheye-calib/calib_results.txt"),
                root / "cam0" / "calib_results.txt");
  const Dataset ds = loadDataset(root);
  ASSERT_TRUE(ds.camera);
  EXPECT_EQ(camera::modelName(*ds.camera), "ocam");
  EXPECT_EQ(camera::width(*ds.camera), 640);
  EXPECT_EQ(camera::height(*ds.camera), 480);
}

// Each case damages one file of the mini dataset and names what the error must contain (with
// RecordPolicy::strict). By default a bad record in the middle of a stream is skipped instead
// (skipped_reason: how it is counted); a stream left with no record is an error either way.
struct Damage {
  const char* name;
  const char* file;     // relative to the dataset root; empty: remove the calibration
  const char* content;  // new content
  const char* expected;
  const char* skipped_reason = nullptr;  // by default: skipped, counted under this reason
};

TEST(Dataset, BadInputGivesAnErrorNamingFileAndLine) {
  const Damage cases[] = {
      {"image_list_columns", "cam0/data.csv", "#t,f\n1000000000,1000000000.png,extra\n",
       "cam0/data.csv:2: expected 2 columns"},
      {"image_list_order", "cam0/data.csv",
       "1050000000,1050000000.png\n1000000000,1000000000.png\n",
       "cam0/data.csv:2: time stamps must increase", "stamp_backwards"},
      {"image_missing", "cam0/data.csv", "1000000000,nope.png\n", "cam0/data.csv:1: image file"},
      {"image_list_empty", "cam0/data.csv", "#timestamp [ns],filename\n", "no images listed"},
      {"imu_columns", "imu0/data.csv", "#h\n1000000000,0.1,0.2,0.3,0,0\n",
       "imu0/data.csv:2: expected 7 columns"},
      {"imu_nan", "imu0/data.csv", "1000000000,0.1,nan,0.3,0,0,9.8\n",
       "imu0/data.csv:1: expected a finite number for w_y"},
      {"imu_order", "imu0/data.csv", "2,0,0,0,0,0,0\n1,0,0,0,0,0,0\n",
       "imu0/data.csv:2: time stamps must increase", "stamp_backwards"},
      // Finite but no gyro's: such a rate overflowed the rotation integration (a Ceres abort).
      {"imu_huge_rate", "imu0/data.csv", "1,0,0,0,0,0,9.8\n2,0,0,-1e200,0,0,9.8\n",
       "imu0/data.csv:2: w_z = -1e+200 rad/s is no gyro reading", "out_of_range"},
      {"lidar_columns", "lidar0/data.csv",
       "1000000000,-1,0.5,0.1,30,1,2\n1100000000,-1,0.5,0.1,30,1\n",
       "lidar0/data.csv:2: expected 7 columns like the first scan", "columns"},
      {"lidar_header_nan", "lidar0/data.csv", "1000000000,nan,0.5,0.1,30,1,2\n",
       "lidar0/data.csv:1: expected a finite number for angle_min"},
      {"lidar_ranges", "lidar0/data.csv", "1000000000,-1,0.5,30,0.1,1,2\n",
       "lidar0/data.csv:1: expected 0 <= range_min < range_max"},
      {"gt_far", "groundtruth.txt", "1.0 0 0 0 0 0 0 1\n1.1 1e200 0 0 0 0 0 1\n",
       "groundtruth.txt:2: position (1e+200, 0, 0) m is beyond any trajectory"},
      {"gt_order", "groundtruth.txt", "2.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n",
       "groundtruth.txt:2: time stamps must not decrease"},
      {"bias_columns", "sim/truth_bias.csv", "1000000000,0.1,0.2\n",
       "sim/truth_bias.csv:1: expected 4 columns"},
      {"rig_unknown_key", "rig.yaml", "camera: {rate_hz: 20.0, colour: red}\n", "camera.colour"},
      {"rig_bad_value", "rig.yaml", "gyro: {rate_hz: -5}\n", "gyro.rate_hz"},
      {"rig_not_rigid", "rig.yaml", "T_B_C: [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n",
       "key 'T_B_C': expected a rigid transform"},
      // In millimetres: ran on with scale errors of thousands of percent (1e300: NaN metrics).
      {"rig_translation_mm", "rig.yaml",
       "T_B_C: [1, 0, 0, 350, 0, 1, 0, 0, 0, 0, 1, 700, 0, 0, 0, 1]\n",
       "key 'T_B_C': translation 782.6 m from the body origin; expected metres (at most 10 m)"},
      {"rig_short_matrix", "rig.yaml", "T_B_L: [1, 0, 0]\n", "T_B_L"},
      {"calib_corrupt", "cam0/sensor.yaml", "camera_model: [unclosed\n", "cam0/sensor.yaml"},
      {"calib_incomplete", "cam0/sensor.yaml", "camera_model: pinhole\nresolution: [64, 48]\n",
       "cam0/sensor.yaml"},
      {"calib_missing", "", "", "no camera calibration"},
      {"imu_empty", "imu0/data.csv", "", "imu0/data.csv: no IMU samples"},
      {"lidar_empty", "lidar0/data.csv", "#header only\n", "lidar0/data.csv: no LiDAR scans"},
      {"gt_empty", "groundtruth.txt", "", "groundtruth.txt: no poses found"},
      {"rig_empty_is_defaults_but_bad_yaml", "rig.yaml", "T_B_C: [1, 2\n", "rig.yaml"},
  };
  for (const auto& c : cases) {
    const fs::path root = writeMiniDataset(test::tempDir() / c.name);
    if (std::string(c.file).empty())
      fs::remove(root / "cam0" / "sensor.yaml");
    else
      test::writeTextFile(root / c.file, c.content);
    const std::string err =
        errorOf([&] { loadDataset(root, {.rig = {}, .topics = {}, .strict = true}); });
    EXPECT_CONTAINS(err, c.expected) << " (case " << c.name << ")";
    if (c.skipped_reason) {
      const Dataset ds = loadDataset(root);
      EXPECT_EQ(ds.skipped.total(), 1) << c.name;
      ASSERT_EQ(ds.skipped.kinds().size(), 1u) << c.name;
      EXPECT_EQ(ds.skipped.kinds()[0].reason, c.skipped_reason) << c.name;
      EXPECT_CONTAINS(ds.skipped.kinds()[0].first, c.expected);
    } else {
      EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), c.expected)
          << " (case " << c.name << ")";
    }
  }
}

// A day's log has a few bad records: each is skipped and counted by sensor and reason, and the
// records around it load as they are.
TEST(Dataset, BadRecordsInTheMiddleOfAStreamAreSkippedAndCounted) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  test::writeTextFile(root / "imu0" / "data.csv",
                      "#t,wx,wy,wz,ax,ay,az\n"
                      "1000000000,0.1,0.2,0.3,0,0,9.81\n"
                      "1005000000,0.1,nan,0.3,0,0,9.81\n"  // non_finite
                      "1010000000,0.1,0.2,0.3,0,0,9.81\n"
                      "1015000000,0.1,0.2,garbage,0,0,9.81\n"  // unparsable
                      "1020000000,0.1,0.2,inf,0,0,9.81\n"      // non_finite
                      "1020000000,0.1,0.2,0.3,0,0\n"           // columns
                      "1025000000,0.1,0.2,0.3,0,0,9.81\n"
                      "1025000000,0.4,0.2,0.3,0,0,9.81\n"  // stamp_duplicate
                      "1005000000,0.4,0.2,0.3,0,0,9.81\n"  // stamp_backwards
                      "9000000000,0.4,0.2,0.3,0,0,9.81\n"  // stamp_ahead (seen at the next)
                      "1030000000,0.1,0.2,0.3,0,0,9.81\n");
  test::writeTextFile(root / "lidar0" / "data.csv",
                      "1000000000,-1.5,0.5,0.1,30,1.0,2.0,3.0\n"
                      "1050000000,-1.5,0.5,0.1,30,1.0,2.0\n"         // columns
                      "1100000000,-1.5,0.5,30,0.1,1.0,2.0,3.0\n"     // bad_header
                      "1150000000,-1.5,0.5,0.1,30,-1.0,nan,inf\n");  // no returns: kept
  fs::remove(root / "cam0" / "data" / "1050000000.png");
  const Dataset ds = loadDataset(root);
  ASSERT_EQ(ds.imu.size(), 4u);
  EXPECT_EQ(ds.imu[1].t_ns, 1010000000);
  EXPECT_EQ(ds.imu[2].t_ns, 1025000000);
  EXPECT_DOUBLE_EQ(ds.imu[2].gyro_radps.x(), 0.1);  // the first of the duplicates
  EXPECT_EQ(ds.imu[3].t_ns, 1030000000);
  ASSERT_EQ(ds.scans.size(), 2u);
  EXPECT_FALSE(ds.scans[1].valid(0));
  ASSERT_EQ(ds.images.size(), 2u);
  EXPECT_EQ(ds.images[1].t_ns, 1100000000);
  const nlohmann::json expected = {{"gyro",
                                    {{"non_finite", 2},
                                     {"unparsable", 1},
                                     {"columns", 1},
                                     {"stamp_duplicate", 1},
                                     {"stamp_backwards", 1},
                                     {"stamp_ahead", 1}}},
                                   {"lidar", {{"columns", 1}, {"bad_header", 1}}},
                                   {"camera", {{"missing_file", 1}}}};
  EXPECT_EQ(ds.skipped.toJson(), expected) << ds.skipped.toJson().dump();
  EXPECT_EQ(ds.skipped.total(), 10);
  // The first of each kind names the file and line.
  EXPECT_EQ(ds.skipped.kinds()[0].sensor, "camera");
  EXPECT_CONTAINS(ds.skipped.kinds()[0].first, "cam0/data.csv:3: image file");
  for (const auto& k : ds.skipped.kinds()) {
    if (k.reason == "stamp_ahead") {
      EXPECT_CONTAINS(k.first, "imu0/data.csv:11: time stamp 9000000000 ns is ahead");
    }
  }
  // --strict: the first bad record is the error.
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root, {.rig = {}, .topics = {}, .strict = true}); }),
                  "cam0/data.csv:3: image file");
  // A stream with no usable record left is a bad file.
  test::writeTextFile(root / "imu0" / "data.csv", "1,nan,0,0,0,0,0\n2,x,0,0,0,0,0\n");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }),
                  "imu0/data.csv: no usable record (every one is bad; the first: ");
}

TEST(Dataset, ImageThatDoesNotDecodeNamesTheFile) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  const Dataset ds = loadDataset(root);
  test::writeTextFile(ds.images[1].path, "this is not a png");
  const std::string err = errorOf([&] { loadImageGrey(ds.images[1]); });
  EXPECT_CONTAINS(err, ds.images[1].path.string() + ": cannot decode the image");
  fs::remove(ds.images[2].path);
  EXPECT_CONTAINS(errorOf([&] { loadImageGrey(ds.images[2]); }), "image file not found");
}

TEST(Dataset, ImageOfAnotherSizeThanTheCalibrationNamesBoth) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  const Dataset ds = loadDataset(root);
  EXPECT_EQ(loadDatasetImage(ds, 0).cols, 64);
  cv::imwrite(ds.images[1].path.string(), cv::Mat(24, 32, CV_8UC1, cv::Scalar(9)));
  const std::string err = errorOf([&] { loadDatasetImage(ds, 1); });
  EXPECT_CONTAINS(err, ds.images[1].path.string() + ": the image is 32x24");
  EXPECT_CONTAINS(err, (root / "cam0" / "sensor.yaml").string() + ") is for 64x48 images");
}

TEST(Dataset, ByteOrderMarkBeforeTheFirstLineIsIgnored) {
  const fs::path root = writeMiniDataset(test::tempDir() / "ds");
  test::writeTextFile(root / "imu0" / "data.csv",
                      "\xEF\xBB\xBF#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n"
                      "1000000000,0.1,0.2,0.3,0,0,9.81\n");
  test::writeTextFile(root / "groundtruth.txt",
                      "\xEF\xBB\xBF"
                      "1.0 0.5 0 0 0 0 0 1\n");
  const Dataset ds = loadDataset(root);
  ASSERT_EQ(ds.imu.size(), 1u);
  EXPECT_DOUBLE_EQ(ds.imu[0].gyro_radps.z(), 0.3);
  ASSERT_EQ(ds.groundtruth.size(), 1u);
  EXPECT_DOUBLE_EQ(ds.groundtruth[0].T_W_B.translation().x(), 0.5);
}

TEST(Dataset, NotADatasetFolder) {
  const fs::path root = test::tempDir();
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root / "missing"); }), "dataset folder not found");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "not a dataset folder");
}

TEST(Dataset, BrokenKittiFolders) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  const fs::path root = test::tempDir() / "kitti";
  fs::create_directories(root / "image_0");
  fs::copy_file(test::sharedData("kitti07-first160/image_0/000000.png"),
                root / "image_0" / "000000.png");
  fs::copy_file(test::sharedData("kitti07-first160/image_0/000001.png"),
                root / "image_0" / "000001.png");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "calib.txt");
  test::writeTextFile(root / "calib.txt", "P1: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  test::writeTextFile(root / "times.txt", "0.0\n0.1\n");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "no 'P0:' row");
  test::writeTextFile(root / "calib.txt", "P0: 700 0 600 0 0 700 180 0 0 0 1\n");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }),
                  "calib.txt:1: expected 'P0:' and 12 numbers");
  test::writeTextFile(root / "calib.txt", "P0: 700 0 600 0 0 700 180 0 0 0 1 0\n");
  test::writeTextFile(root / "times.txt", "0.0\n");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "frame 1 has no time stamp");
  test::writeTextFile(root / "times.txt", "0.0\n0.1\n");
  // A number too long for stoul was an "internal error: stoul".
  test::writeTextFile(root / "image_0" / "99999999999999999999999.png", "x");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }),
                  "99999999999999999999999.png: expected a frame number of at most 9 digits");
  fs::remove(root / "image_0" / "99999999999999999999999.png");
  test::writeTextFile(root / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "poses.txt:2: expected 12 values");
  test::writeTextFile(root / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0.5\n");
  const Dataset ds = loadDataset(root);
  ASSERT_EQ(ds.groundtruth.size(), 2u);
  EXPECT_EQ(ds.groundtruth[1].t_ns, 100000000);  // from times.txt
  test::writeTextFile(root / "image_0" / "000001.png", "garbage");
  test::writeTextFile(root / "image_0" / "000000.png", "garbage");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(root); }), "000000.png: cannot decode the image");
}

TEST(Dataset, SensorsOnAnotherClockAreNamed) {
  Dataset d;
  for (Timestamp t : {1'000'000'000, 1'050'000'000, 2'000'000'000})
    d.images.push_back({t, "x.png"});
  ImuSample g;
  for (Timestamp t : {1'000'000, 2'000'000}) {  // another clock: 1 and 2 ms after its own start
    g.t_ns = t;
    d.imu.push_back(g);
  }
  LidarScan scan;
  scan.t_ns = 1'500'000'000;  // inside the camera's span
  d.scans = {scan};
  Trajectory gt(2);
  gt[0].t_ns = 1'999'000'000;  // overlaps at the end
  gt[1].t_ns = 3'000'000'000;
  auto notes = clockOverlapNotes(d, gt);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_CONTAINS(notes[0],
                  "gyro: its 2 stamps (0.001 .. 0.002 s) do not overlap the camera's "
                  "(1.000 .. 2.000 s), so it is not used");
  gt[0].t_ns = 2'001'000'000;  // starts after the last frame
  notes = clockOverlapNotes(d, gt);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_CONTAINS(notes[1], "ground truth: its 2 stamps");
  EXPECT_TRUE(clockOverlapNotes(Dataset{}, gt).empty());
}

}  // namespace
}  // namespace ovo::io
