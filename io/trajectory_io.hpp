// Trajectory files: TUM (`t[s] tx ty tz qx qy qz qw`), KITTI (3x4 row-major, optional leading
// time) and the EuRoC ground-truth csv; and the gyro-bias history csv written beside them.
// Readers throw ovo::Error naming the file and line.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "common/types.hpp"

namespace ovo::io {

enum class TrajectoryFormat { kAuto, kTum, kKitti, kEurocCsv };

/// "tum", "kitti", "euroc" or "auto" -> format; throws ovo::Error for anything else.
TrajectoryFormat parseTrajectoryFormat(const std::string& name);
std::string formatName(TrajectoryFormat format);

/// A trajectory as read from a file, with what the reader found out about it.
struct TrajectoryFile {
  Trajectory poses;
  TrajectoryFormat format = TrajectoryFormat::kTum;
  bool has_time = true;  // false for KITTI files without a time column (stamps = index seconds)
};

/// TUM: one pose a line, '#' comments. Quaternions are normalised (an all-zero one is an error).
/// Time stamps must not decrease (equal stamps are kept, as evo does).
Trajectory readTum(const std::filesystem::path& file);
/// KITTI: 12 numbers (row-major [R|t]) or 13 with a leading time in seconds. Without times the
/// i-th pose gets t = i seconds (*has_time = false). The rotation is kept as written (evo does
/// too).
Trajectory readKitti(const std::filesystem::path& file, bool* has_time = nullptr);
/// EuRoC state_groundtruth_estimate0/data.csv: t_ns, p_x p_y p_z, q_w q_x q_y q_z, ... (>= 8
/// columns, the same count on every row).
Trajectory readEurocGroundtruthCsv(const std::filesystem::path& file);

/// Reads with the given format, or detects it (kAuto): a ".csv" or a first data row with a comma
/// and an integer nanosecond stamp is EuRoC, 8 columns TUM, 12 or 13 KITTI.
TrajectoryFile readTrajectory(const std::filesystem::path& file,
                              TrajectoryFormat format = TrajectoryFormat::kAuto);

/// Writers go through a temporary file and a rename: nothing is ever half-written.
/// TUM: times with 9 decimals, poses with round-trip precision.
void writeTum(const std::filesystem::path& file, const Trajectory& trajectory);
/// KITTI: 12 numbers a row; with_time puts the time in seconds first.
void writeKitti(const std::filesystem::path& file, const Trajectory& trajectory,
                bool with_time = false);
/// Gyro bias over time: `#timestamp [ns],b_x [rad s^-1],b_y [rad s^-1],b_z [rad s^-1]`, one row a
/// time (the simulator's sim/truth_bias.csv and `ovo run`'s gyro_bias.csv).
void writeGyroBiasCsv(const std::filesystem::path& file,
                      const std::vector<std::pair<Timestamp, Vec3>>& bias);
/// Reads that file back: 4 columns a row, strictly increasing times.
std::vector<std::pair<Timestamp, Vec3>> readGyroBiasCsv(const std::filesystem::path& file);

}  // namespace ovo::io
