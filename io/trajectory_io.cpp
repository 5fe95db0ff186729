#include "io/trajectory_io.hpp"

#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "common/error.hpp"
#include "io/text_reader.hpp"

namespace ovo::io {

TrajectoryFormat parseTrajectoryFormat(const std::string& name) {
  if (name == "auto") return TrajectoryFormat::kAuto;
  if (name == "tum") return TrajectoryFormat::kTum;
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "euroc") return TrajectoryFormat::kEurocCsv;
  fail("unknown trajectory format '{}': expected tum, kitti, euroc or auto", name);
}

std::string formatName(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kAuto:
      return "auto";
    case TrajectoryFormat::kTum:
      return "tum";
    case TrajectoryFormat::kKitti:
      return "kitti";
    case TrajectoryFormat::kEurocCsv:
      return "euroc";
  }
  return "?";
}

namespace {

void checkOrder(const TextReader& in, const Trajectory& trajectory, Timestamp t_ns) {
  if (!trajectory.empty() && t_ns < trajectory.back().t_ns)
    in.fail("time stamps must not decrease: {} s after {} s", formatSeconds(t_ns),
            formatSeconds(trajectory.back().t_ns));
}

void checkNotEmpty(const TextReader& in, const Trajectory& trajectory, std::string_view what) {
  if (trajectory.empty()) ovo::fail("{}: no poses found (expected {})", in.fileName(), what);
}

// No robot is farther than this from its world origin (the Moon is 3.8e8 m away); larger
// coordinates are corrupt and would overflow the metrics' sums of squares.
constexpr double kMaxPositionM = 1e9;

void checkPosition(const TextReader& in, const Vec3& p) {
  if (p.cwiseAbs().maxCoeff() > kMaxPositionM)
    in.fail("position ({}, {}, {}) m is beyond any trajectory (expected coordinates within {:g} m)",
            p.x(), p.y(), p.z(), kMaxPositionM);
}

// KITTI files hold the rotation's 9 numbers, printed to 6-9 digits: rounding leaves them
// orthonormal to about 1e-6, a scaled, zero or mirrored matrix is far off.
constexpr double kRotationTolerance = 1e-3;

void checkRotation(const TextReader& in, const Mat3& R) {
  const double off = (R.transpose() * R - Mat3::Identity()).norm();
  if (!(off <= kRotationTolerance) || R.determinant() < 0.0)
    in.fail(
        "the 3x3 part is not a rotation (|R^T R - I| = {:.3g}, det {:.3g}; expected an "
        "orthonormal matrix with determinant +1)",
        off, R.determinant());
}

SE3 poseFromQuaternion(const TextReader& in, const Vec3& p, double qw, double qx, double qy,
                       double qz) {
  checkPosition(in, p);
  Quat q(qw, qx, qy, qz);
  const double norm = q.norm();
  if (!(norm > 1e-6)) in.fail("the quaternion has zero length");
  q.coeffs() /= norm;
  SE3 T = SE3::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = p;
  return T;
}

}  // namespace

Trajectory readTum(const std::filesystem::path& file) {
  constexpr std::string_view kWhat = "a TUM trajectory: t[s] tx ty tz qx qy qz qw";
  TextReader in(file, kWhat);
  Trajectory trajectory;
  std::vector<std::string_view> tok;
  while (in.next(tok)) {
    if (tok.size() != 8) in.fail("expected 8 values (t tx ty tz qx qy qz qw), got {}", tok.size());
    StampedPose pose;
    pose.t_ns = in.secondsToNs(tok[0], "the time [s]");
    const Vec3 p(in.number(tok[1], "tx"), in.number(tok[2], "ty"), in.number(tok[3], "tz"));
    pose.T_W_B = poseFromQuaternion(in, p, in.number(tok[7], "qw"), in.number(tok[4], "qx"),
                                    in.number(tok[5], "qy"), in.number(tok[6], "qz"));
    checkOrder(in, trajectory, pose.t_ns);
    trajectory.push_back(pose);
  }
  checkNotEmpty(in, trajectory, kWhat);
  return trajectory;
}

Trajectory readKitti(const std::filesystem::path& file, bool* has_time) {
  constexpr std::string_view kWhat =
      "KITTI poses: 12 numbers of a 3x4 [R|t] a row, optional time first";
  TextReader in(file, kWhat);
  Trajectory trajectory;
  std::vector<std::string_view> tok;
  std::size_t columns = 0;
  while (in.next(tok)) {
    if (tok.size() != 12 && tok.size() != 13)
      in.fail("expected 12 values (3x4 pose, row-major) or 13 (time, then the pose), got {}",
              tok.size());
    if (columns == 0) columns = tok.size();
    if (tok.size() != columns)
      in.fail("expected {} values like the first row, got {}", columns, tok.size());
    const std::size_t first = columns - 12;
    StampedPose pose;
    pose.t_ns = first == 1 ? in.secondsToNs(tok[0], "the time [s]")
                           : static_cast<Timestamp>(trajectory.size()) * 1000000000;
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        M(r, c) = in.number(tok[first + 4 * r + c], fmt::format("element ({}, {})", r, c));
    checkPosition(in, M.block<3, 1>(0, 3));
    checkRotation(in, M.topLeftCorner<3, 3>());
    pose.T_W_B.matrix() = M;
    checkOrder(in, trajectory, pose.t_ns);
    trajectory.push_back(pose);
  }
  checkNotEmpty(in, trajectory, kWhat);
  if (has_time) *has_time = columns == 13;
  return trajectory;
}

Trajectory readEurocGroundtruthCsv(const std::filesystem::path& file) {
  constexpr std::string_view kWhat =
      "EuRoC ground truth csv: t[ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...";
  TextReader in(file, kWhat);
  Trajectory trajectory;
  std::vector<std::string_view> tok;
  std::size_t columns = 0;
  while (in.next(tok)) {
    if (tok.size() < 8)
      in.fail("expected at least 8 columns (t[ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z), got {}",
              tok.size());
    if (columns == 0) columns = tok.size();
    if (tok.size() != columns)
      in.fail("expected {} columns like the first row, got {}", columns, tok.size());
    StampedPose pose;
    pose.t_ns = in.integer(tok[0], "the time stamp [ns]");
    const Vec3 p(in.number(tok[1], "p_x"), in.number(tok[2], "p_y"), in.number(tok[3], "p_z"));
    pose.T_W_B = poseFromQuaternion(in, p, in.number(tok[4], "q_w"), in.number(tok[5], "q_x"),
                                    in.number(tok[6], "q_y"), in.number(tok[7], "q_z"));
    for (std::size_t i = 8; i < tok.size(); ++i) in.number(tok[i], fmt::format("column {}", i + 1));
    checkOrder(in, trajectory, pose.t_ns);
    trajectory.push_back(pose);
  }
  checkNotEmpty(in, trajectory, kWhat);
  return trajectory;
}

namespace {

TrajectoryFormat detectFormat(const std::filesystem::path& file) {
  constexpr std::string_view kWhat = "a trajectory (TUM, KITTI or EuRoC csv)";
  TextReader in(file, kWhat);
  std::vector<std::string_view> tok;
  if (!in.next(tok)) fail("{}: no poses found (expected {})", file.string(), kWhat);
  const bool comma = in.line().find(',') != std::string::npos;
  if (comma && tok.size() >= 8) return TrajectoryFormat::kEurocCsv;
  if (tok.size() == 8) return TrajectoryFormat::kTum;
  if (tok.size() == 12 || tok.size() == 13) return TrajectoryFormat::kKitti;
  in.fail(
      "cannot tell the trajectory format from {} values (expected 8 for TUM, 12 or 13 for "
      "KITTI, or a csv row of at least 8 for EuRoC)",
      tok.size());
}

}  // namespace

TrajectoryFile readTrajectory(const std::filesystem::path& file, TrajectoryFormat format) {
  TrajectoryFile out;
  out.format = format == TrajectoryFormat::kAuto ? detectFormat(file) : format;
  switch (out.format) {
    case TrajectoryFormat::kTum:
      out.poses = readTum(file);
      break;
    case TrajectoryFormat::kKitti:
      out.poses = readKitti(file, &out.has_time);
      break;
    case TrajectoryFormat::kEurocCsv:
      out.poses = readEurocGroundtruthCsv(file);
      break;
    case TrajectoryFormat::kAuto:
      break;
  }
  return out;
}

void writeTum(const std::filesystem::path& file, const Trajectory& trajectory) {
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out), "# t[s] tx ty tz qx qy qz qw\n");
  for (const auto& pose : trajectory) {
    const Quat q(pose.T_W_B.linear());
    const Vec3& p = pose.T_W_B.translation();
    fmt::format_to(std::back_inserter(out), "{} {} {} {} {} {} {} {}\n", formatSeconds(pose.t_ns),
                   p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
  }
  writeFileAtomically(file, fmt::to_string(out));
}

void writeKitti(const std::filesystem::path& file, const Trajectory& trajectory, bool with_time) {
  fmt::memory_buffer out;
  for (const auto& pose : trajectory) {
    if (with_time) fmt::format_to(std::back_inserter(out), "{} ", formatSeconds(pose.t_ns));
    const Eigen::Matrix4d M = pose.T_W_B.matrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        fmt::format_to(std::back_inserter(out), "{}{}", M(r, c), r == 2 && c == 3 ? "\n" : " ");
  }
  writeFileAtomically(file, fmt::to_string(out));
}

void writeGyroBiasCsv(const std::filesystem::path& file,
                      const std::vector<std::pair<Timestamp, Vec3>>& bias) {
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out),
                 "#timestamp [ns],b_x [rad s^-1],b_y [rad s^-1],b_z [rad s^-1]\n");
  for (const auto& [t, b] : bias)
    fmt::format_to(std::back_inserter(out), "{},{},{},{}\n", t, b.x(), b.y(), b.z());
  writeFileAtomically(file, fmt::to_string(out));
}

std::vector<std::pair<Timestamp, Vec3>> readGyroBiasCsv(const std::filesystem::path& csv) {
  TextReader in(csv, "a gyro bias over time: t[ns], b_x, b_y, b_z [rad/s]");
  std::vector<std::pair<Timestamp, Vec3>> bias;
  std::vector<std::string_view> tok;
  while (in.next(tok)) {
    if (tok.size() != 4)
      in.fail("expected 4 columns (t[ns], b_x, b_y, b_z [rad/s]), got {}", tok.size());
    const Timestamp t = in.integer(tok[0], "the time stamp [ns]");
    checkIncreasing(in, bias.empty() ? 0 : bias.back().first, t, bias.empty());
    bias.emplace_back(
        t, Vec3(in.number(tok[1], "b_x"), in.number(tok[2], "b_y"), in.number(tok[3], "b_z")));
  }
  return bias;
}

}  // namespace ovo::io
