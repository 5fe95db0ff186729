// `ovo convert`: reads any dataset ovo reads (a bag: ROS 1 .bag, rosbag2 .db3 or folder, MCAP;
// or a dataset folder) and writes it as an ovo dataset folder (EuRoC layout, the default) or as a
// bag beside its rig.yaml and calibration (--format rosbag|db3|mcap), through a staging folder:
// a failed conversion leaves nothing behind.
#include <spdlog/spdlog.h>

#include <optional>

#include "apps/command.hpp"
#include "common/error.hpp"
#include "io/bag_writer.hpp"
#include "io/dataset.hpp"
#include "io/dataset_writer.hpp"

namespace ovo::app {
namespace {

struct ConvertArgs {
  std::string in, out, rig, topics, format = "folder";
  bool overwrite = false;
};

int runConvert(const ConvertArgs& args) {
  const std::optional<io::BagFormat> bag_format =
      args.format == "folder" ? std::nullopt : std::optional(io::parseBagFormat(args.format));
  const io::Dataset data = io::loadDataset(args.in, {args.rig, args.topics});
  if (!data.camera) fail("{}: the dataset has no camera calibration", args.in);
  for (const auto& note : data.notes) spdlog::info("{}", note);
  spdlog::info("convert: {} ({} images, {} gyro samples, {} scans) -> {} ({})", args.in,
               data.images.size(), data.imu.size(), data.scans.size(), args.out, args.format);

  io::DatasetWriter writer(args.out, args.overwrite, bag_format);
  const std::size_t n = data.images.size();
  for (std::size_t i = 0; i < n; ++i) {
    writer.writeImage(data.images[i].t_ns, io::loadDatasetImage(data, i));
    if ((i + 1) % std::max<std::size_t>(1, n / 10) == 0)
      spdlog::info("convert: {}/{} images", i + 1, n);
  }
  if (!data.imu.empty()) writer.writeImu(data.imu);
  if (!data.scans.empty()) writer.writeLidar(data.scans);
  if (!data.groundtruth.empty()) writer.writeGroundTruth(data.groundtruth);
  if (!data.true_gyro_bias.empty()) writer.writeTrueGyroBias(data.true_gyro_bias);
  writer.writeCamera(*data.camera, data.rig.T_B_C, data.rig.camera_rate_hz);
  io::RigInfo rig = data.rig;
  rig.has_rig_file = true;
  writer.writeRig(rig);
  writer.commit();
  spdlog::info("convert: wrote {}", args.out);
  return 0;
}

CommandRunner setupConvert(CLI::App& sub) {
  auto args = std::make_shared<ConvertArgs>();
  sub.add_option("--in", args->in,
                 "A bag (.bag, .db3, .mcap, a rosbag2 folder) or a dataset folder")
      ->required();
  sub.add_option("--out", args->out, "Dataset folder to create")->required();
  sub.add_option("--rig", args->rig,
                 "Rig file for a bag (default: rig.yaml beside the bag); names the camera "
                 "calibration with camera.calibration");
  sub.add_option("--topics", args->topics,
                 "Topics of a bag: camera=NAME,imu=NAME,lidar=NAME (default: the one topic of "
                 "each type; none leaves a sensor out)");
  sub.add_option("--format", args->format,
                 "folder (EuRoC layout), or a bag beside rig.yaml: rosbag (ROS 1), db3 (rosbag2 "
                 "sqlite3), mcap")
      ->check(CLI::IsMember({"folder", "rosbag", "db3", "mcap"}))
      ->capture_default_str();
  sub.add_flag("--overwrite", args->overwrite, "Replace --out if it exists");
  return [args] { return runConvert(*args); };
}

}  // namespace

OVO_REGISTER_COMMAND(convert, "Convert a bag (ROS 1, rosbag2 sqlite3, MCAP) or a dataset folder",
                     setupConvert);

}  // namespace ovo::app
