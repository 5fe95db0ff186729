// Fuzz targets for a dataset folder's sensor streams, read through loadDataset as `ovo run` reads
// them, with the default policy (bad records skipped) and strict: the image list
// (cam0/data.csv), the gyro (imu0/data.csv), the LiDAR scans (lidar0/data.csv), and a KITTI
// folder's calib.txt, times.txt and poses file (the input split in three at the first two
// lines holding only "---"). The rest of the folder is a fixed, valid mini dataset.
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "io/dataset.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace {

namespace fs = std::filesystem;

// A valid ovo dataset (two 16x12 images, a pinhole sensor.yaml, a gyro and a LiDAR file),
// made once per process; the targets overwrite one of its files.
const fs::path& miniDataset() {
  static const fs::path root = [] {
    const fs::path root = ovo::fuzz::scratchDir() / "ds";
    fs::create_directories(root / "cam0" / "data");
    const cv::Mat image(12, 16, CV_8UC1, cv::Scalar(100));
    cv::imwrite((root / "cam0" / "data" / "a.png").string(), image);
    cv::imwrite((root / "cam0" / "data" / "b.png").string(), image);
    ovo::fuzz::writeScratch("ds/cam0/sensor.yaml",
                            "sensor_type: camera\nrate_hz: 20\nresolution: [16, 12]\n"
                            "camera_model: pinhole\nintrinsics: [10.0, 10.0, 7.5, 5.5]\n"
                            "distortion_model: radial-tangential\n"
                            "distortion_coefficients: [0, 0, 0, 0]\n");
    return root;
  }();
  return root;
}

constexpr const char* kImageList = "#timestamp [ns],filename\n1000,a.png\n2000,b.png\n";
constexpr const char* kImu = "1000,0.1,0.2,0.3,0,0,9.81\n2000,0.1,0.2,0.3,0,0,9.81\n";
constexpr const char* kLidar = "1000,-1,0.5,0.1,30,1.0,nan,2.5\n2000,-1,0.5,0.1,30,1.1,1.2,inf\n";

// Writes the mini dataset's three stream files, `file` with the fuzzer's input, and loads it
// with both policies.
void loadWith(const char* file, ovo::fuzz::Bytes input) {
  const fs::path& root = miniDataset();
  ovo::fuzz::writeScratch("ds/cam0/data.csv", kImageList);
  ovo::fuzz::writeScratch("ds/imu0/data.csv", kImu);
  ovo::fuzz::writeScratch("ds/lidar0/data.csv", kLidar);
  ovo::fuzz::writeScratch(std::string("ds/") + file, input);
  for (const bool strict : {false, true})
    ovo::fuzz::expectOnlyOvoErrors([&] {
      const ovo::io::Dataset ds =
          ovo::io::loadDataset(root, {.rig = {}, .topics = {}, .strict = strict});
      (void)ovo::io::clockOverlapNotes(ds, ds.groundtruth);
      (void)ds.skipped.toJson();
    });
}

}  // namespace

OVO_FUZZ_TARGET(image_list_csv) { loadWith("cam0/data.csv", input); }
OVO_FUZZ_TARGET(imu_csv) { loadWith("imu0/data.csv", input); }
OVO_FUZZ_TARGET(lidar_csv) { loadWith("lidar0/data.csv", input); }

OVO_FUZZ_TARGET(kitti_folder) {
  static const fs::path root = [] {
    const fs::path root = ovo::fuzz::scratchDir() / "kitti";
    fs::create_directories(root / "image_0");
    const cv::Mat image(12, 16, CV_8UC1, cv::Scalar(100));
    cv::imwrite((root / "image_0" / "000000.png").string(), image);
    cv::imwrite((root / "image_0" / "000001.png").string(), image);
    return root;
  }();
  const std::string text(reinterpret_cast<const char*>(input.data()), input.size());
  std::string parts[3];
  std::size_t part = 0, start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(start, end - start);
    if (line == "---" && part < 2)
      ++part;
    else
      parts[part] += line + (end < text.size() ? "\n" : "");
    start = end + 1;
  }
  ovo::fuzz::writeScratch("kitti/calib.txt", parts[0]);
  ovo::fuzz::writeScratch("kitti/times.txt", parts[1]);
  ovo::fuzz::writeScratch("kitti/poses.txt", parts[2]);
  ovo::fuzz::expectOnlyOvoErrors([&] {
    const ovo::io::Dataset ds = ovo::io::loadDataset(root);
    (void)ovo::io::readGroundtruthFor(ds, root / "poses.txt");
  });
}
