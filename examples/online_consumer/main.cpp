// online_consumer: feeds a dataset folder's images, gyro samples and LiDAR scans through ovo's
// public API (<ovo/ovo.hpp>) in time order, as a robot's driver callbacks would, and prints one
// pose per processed frame (TUM: t[s] tx ty tz qx qy qz qw) on standard output.
//
//   online_consumer --dataset DIR [--rig DIR/rig.yaml] [--estimator window|kf|vo] [--realtime]
//                   [--out final_trajectory.txt]
//
// DIR is the ovo/EuRoC layout `ovo simulate` writes: cam0/data.csv + cam0/data/*.png,
// imu0/data.csv (t_ns, w_x, w_y, w_z, a_x, a_y, a_z), lidar0/data.csv (t_ns, angle_min,
// angle_increment, range_min, range_max, ranges...), rig.yaml. Standard error gets a summary.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <ovo/ovo.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {

std::vector<std::vector<std::string>> readCsv(const std::string& file) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

void printPose(std::FILE* out, const ovo::Pose& p) {
  std::fprintf(out, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", p.t_ns * 1e-9, p.position_m[0],
               p.position_m[1], p.position_m[2], p.orientation_xyzw[0], p.orientation_xyzw[1],
               p.orientation_xyzw[2], p.orientation_xyzw[3]);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  bool realtime = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--realtime")
      realtime = true;
    else if (i + 1 < argc && a.rfind("--", 0) == 0)
      args[a] = argv[++i];
    else {
      std::cerr << "usage: online_consumer --dataset DIR [--rig FILE] [--estimator NAME] "
                   "[--realtime] [--out FILE]\n";
      return 2;
    }
  }
  if (!args.count("--dataset")) {
    std::cerr << "online_consumer: --dataset DIR is required\n";
    return 2;
  }
  const std::string dir = args["--dataset"];
  const std::string rig = args.count("--rig") ? args["--rig"] : dir + "/rig.yaml";

  // Every measurement of the folder, tagged by kind, in time order. At equal stamps the image
  // goes before the gyro sample (ovo pairs an image with the first gyro sample at or after it).
  struct Event {
    std::int64_t t_ns;
    int order;  // 0 image, 1 scan, 2 gyro
    std::size_t row;
  };
  const auto images = readCsv(dir + "/cam0/data.csv");
  const auto gyro = readCsv(dir + "/imu0/data.csv");
  const auto scans = readCsv(dir + "/lidar0/data.csv");
  std::vector<Event> events;
  for (std::size_t i = 0; i < images.size(); ++i)
    events.push_back({std::stoll(images[i][0]), 0, i});
  for (std::size_t i = 0; i < scans.size(); ++i) events.push_back({std::stoll(scans[i][0]), 1, i});
  for (std::size_t i = 0; i < gyro.size(); ++i) events.push_back({std::stoll(gyro[i][0]), 2, i});
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.t_ns != b.t_ns ? a.t_ns < b.t_ns : a.order < b.order;
  });

  try {
    ovo::OdometryOptions options;
    if (args.count("--estimator")) options.estimator = args["--estimator"];
    options.realtime = realtime;
    options.use_lidar = !scans.empty();
    options.use_gyro = !gyro.empty();
    ovo::Odometry odometry(rig, options, [](const ovo::Pose& p) { printPose(stdout, p); });
    for (const Event& e : events) {
      if (e.order == 0) {
        const cv::Mat image =
            cv::imread(dir + "/cam0/data/" + images[e.row][1], cv::IMREAD_GRAYSCALE);
        if (image.empty()) throw std::runtime_error("cannot read image " + images[e.row][1]);
        odometry.addImage(e.t_ns, image);
      } else if (e.order == 1) {
        const auto& r = scans[e.row];
        ovo::Scan scan;
        scan.t_ns = e.t_ns;
        scan.angle_min_rad = std::stod(r[1]);
        scan.angle_increment_rad = std::stod(r[2]);
        scan.range_min_m = std::stod(r[3]);
        scan.range_max_m = std::stod(r[4]);
        for (std::size_t k = 5; k < r.size(); ++k) scan.ranges_m.push_back(std::stof(r[k]));
        odometry.addScan(scan);
      } else {
        const auto& r = gyro[e.row];
        ovo::GyroSample s{e.t_ns, std::stod(r[1]), std::stod(r[2]), std::stod(r[3])};
        if (r.size() >= 7) {  // the accelerometer's columns (EuRoC's imu0/data.csv)
          s.ax = std::stod(r[4]);
          s.ay = std::stod(r[5]);
          s.az = std::stod(r[6]);
        }
        odometry.addGyro(s);
      }
    }
    odometry.finish();
    const std::vector<ovo::Pose> trajectory = odometry.trajectory();
    if (args.count("--out")) {
      std::FILE* out = std::fopen(args["--out"].c_str(), "w");
      if (!out) throw std::runtime_error("cannot write " + args["--out"]);
      for (const ovo::Pose& p : trajectory) printPose(out, p);
      std::fclose(out);
    }
    std::cerr << "online_consumer: " << odometry.framesProcessed() << " of " << images.size()
              << " frames processed, " << odometry.framesDropped() << " dropped";
    if (!trajectory.empty())
      std::cerr << "; final pose (" << trajectory.back().position_m[0] << ", "
                << trajectory.back().position_m[1] << ", " << trajectory.back().position_m[2]
                << ") m";
    std::cerr << "\n";
  } catch (const std::exception& e) {
    std::cerr << "online_consumer: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
