// Camera calibration files: OCamCalib `calib_results.txt`, EuRoC `sensor.yaml` and Kalibr camchain
// yamls. Readers throw ovo::Error naming the file (and line) and what was expected.
#pragma once

#include <filesystem>
#include <optional>

#include "camera/camera.hpp"
#include "common/types.hpp"

namespace ovo::camera {

/// calib_results*.txt (or any .txt) -> OCam; *.yaml / *.yml -> EuRoC sensor.yaml (pinhole
/// radial-tangential or equidistant) or Kalibr camchain (cam0; radtan or equidistant).
Camera loadCamera(const std::filesystem::path& file);
/// The exact calib_results.txt format; errors name the file and line.
OcamCamera readOcamCalib(const std::filesystem::path& file, const OcamOptions& options = {});
/// Writes the toolbox's format (with the file's own invpol, params().invpol).
void writeOcamCalib(const std::filesystem::path& file, const OcamCamera& cam);
/// EuRoC-style sensor.yaml for a pinhole-radtan or Kannala-Brandt camera (OCam: throws, use
/// writeOcamCalib).
void writeSensorYaml(const std::filesystem::path& file, const Camera& cam, const SE3& T_B_C,
                     double rate_hz);
/// T_B_C (camera -> body) from sensor.yaml's T_BS, or from a Kalibr camchain's cam0 (T_imu_cam, or
/// the inverse of T_cam_imu); nullopt when the file has none (an OCamCalib file never has).
std::optional<SE3> readSensorYamlExtrinsics(const std::filesystem::path& file);

}  // namespace ovo::camera
