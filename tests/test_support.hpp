// Helpers shared by the test programs: where the real data lives, a skip when it is absent,
// numeric Jacobians, and running the built `ovo` command.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "common/error.hpp"

namespace ovo::test {

/// ../shared/data/<rel> beside the source tree (or $OVO_SHARED_DATA when set).
std::filesystem::path sharedData(const std::string& rel = "");
/// A path inside the source tree, e.g. sourcePath("configs/sim/vineyard_row.yaml").
std::filesystem::path sourcePath(const std::string& rel);
/// A fresh empty temporary folder named after the running test.
std::filesystem::path tempDir();

/// Runs `build/ovo <args>`; returns the exit code; stdout and stderr go to *out / *err when given.
int runOvo(const std::string& args, std::string* out = nullptr, std::string* err = nullptr);

/// Writes `text` to `file` (creating its folder), for tests that build bad input files.
inline void writeTextFile(const std::filesystem::path& file, const std::string& text) {
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out << text;
}

/// The message of the ovo::Error that f() throws, or "<no error>".
template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const ovo::Error& e) {
    return e.what();
  }
  return "<no error>";
}

/// A vector of independent draws `dist(gen)`, one draw a statement, the last component first. In
/// `Vec3(d(g), d(g), d(g))` the order of the draws is unspecified: GCC takes a call's arguments
/// last to first on x86-64 and first to last on aarch64, so such a test saw other data on ARM
/// (docs/speed.md#arm64). Last to first keeps the data the tests were written with.
template <typename Dist, typename Gen>
Eigen::Vector3d draw3(Dist& dist, Gen& gen) {
  const double z = dist(gen);
  const double y = dist(gen);
  const double x = dist(gen);
  return Eigen::Vector3d(x, y, z);
}
template <typename Dist, typename Gen>
Eigen::Vector2d draw2(Dist& dist, Gen& gen) {
  const double y = dist(gen);
  const double x = dist(gen);
  return Eigen::Vector2d(x, y);
}

/// Central-difference Jacobian of f: R^n -> R^m at x.
Eigen::MatrixXd numericJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                const Eigen::VectorXd& x, double h = 1e-6);

}  // namespace ovo::test

/// Skips the test with a message when ../shared/data/<rel> is absent.
#define OVO_REQUIRE_DATA(rel)                                                            \
  do {                                                                                   \
    if (!std::filesystem::exists(::ovo::test::sharedData(rel)))                          \
      GTEST_SKIP() << "shared data not found: " << ::ovo::test::sharedData(rel).string() \
                   << " (tests on real data need ../shared/data beside the project)";    \
  } while (0)

/// Skips a test of ROS 1 bags in a build without them (CMake OVO_WITH_ROS1=OFF, as for arm64);
/// the test file includes io/rosbag1_reader.hpp.
#define OVO_REQUIRE_ROS1()                                                         \
  do {                                                                             \
    if (!::ovo::io::bag::ros1BagsBuilt())                                          \
      GTEST_SKIP() << "this ovo was built without ROS 1 bags (OVO_WITH_ROS1=OFF)"; \
  } while (0)

/// Compares two Jacobians elementwise with a tolerance relative to the larger magnitude.
#define OVO_EXPECT_JACOBIAN_NEAR(J_analytic, J_numeric, tol)                         \
  do {                                                                               \
    const Eigen::MatrixXd _a = (J_analytic);                                         \
    const Eigen::MatrixXd _n = (J_numeric);                                          \
    ASSERT_EQ(_a.rows(), _n.rows());                                                 \
    ASSERT_EQ(_a.cols(), _n.cols());                                                 \
    const double _scale = std::max(1.0, _n.cwiseAbs().maxCoeff());                   \
    EXPECT_LE((_a - _n).cwiseAbs().maxCoeff(), (tol)*_scale) << "analytic:\n"        \
                                                             << _a << "\nnumeric:\n" \
                                                             << _n;                  \
  } while (0)

/// Expects `part` to occur in `text` (an error message, a file's content).
#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "in: " << (text)
