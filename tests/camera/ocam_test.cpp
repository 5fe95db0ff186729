// OCamCalib model: file format, the toolbox's formulas in ovo's axes, invpol round trip,
// Jacobians and the signs of known motions.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "camera/calib_io.hpp"
#include "camera/ocam_camera.hpp"
#include "common/error.hpp"
#include "tests/test_support.hpp"

namespace ovo::camera {
namespace {

constexpr const char* kRomovi = "romovi-fisheye-calib/calib_results.txt";
constexpr const char* kSampleFisheye = "ocam-scaramuzza-sample/calib_results_fisheye.txt";
constexpr const char* kSampleCatadioptric = "ocam-scaramuzza-sample/calib_results_catadioptric.txt";

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double polyval(const std::vector<double>& c, double x) {
  double y = 0.0;
  for (auto it = c.rbegin(); it != c.rend(); ++it) y = y * x + *it;
  return y;
}

// DESIGN section 3's cam2world on (row, col), in OCamCalib's own axes (row, col, backwards).
Vec3 toolboxCam2World(const OcamParams& p, double row, double col) {
  const double inv_det = 1.0 / (p.c - p.d * p.e);
  const double xp = ((row - p.center_row) - p.d * (col - p.center_col)) * inv_det;
  const double yp = (-p.e * (row - p.center_row) + p.c * (col - p.center_col)) * inv_det;
  return Vec3(xp, yp, polyval(p.ss, std::hypot(xp, yp))).normalized();
}

// DESIGN section 3's world2cam: OCamCalib-axes point -> (row, col).
Vec2 toolboxWorld2Cam(const OcamParams& p, const std::vector<double>& invpol, const Vec3& M) {
  const double norm = std::hypot(M.x(), M.y());
  const double theta = std::atan(M.z() / norm);
  const double rho = polyval(invpol, theta);
  const double x = M.x() / norm * rho, y = M.y() / norm * rho;
  return Vec2(x * p.c + y * p.d + p.center_row, x * p.e + y + p.center_col);
}

// |project(unproject(px)) - px| over every valid pixel.
struct PixelRoundTrip {
  double max_px = 0.0, mean_px = 0.0;
  long pixels = 0, failures = 0;
};

PixelRoundTrip pixelRoundTrip(const OcamCamera& cam) {
  PixelRoundTrip out;
  double sum = 0.0;
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const Vec2 px(u, v);
      if (!cam.isValid(px)) continue;
      ++out.pixels;
      const auto bearing = cam.unproject(px);
      const auto back = bearing ? cam.project(*bearing) : std::nullopt;
      if (!back) {
        ++out.failures;
        continue;
      }
      const double err = (*back - px).norm();
      out.max_px = std::max(out.max_px, err);
      sum += err;
    }
  out.mean_px = sum / std::max<long>(1, out.pixels);
  return out;
}

TEST(OcamCalibFile, ReadsRomoviValues) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi));
  const OcamParams& p = cam.params();
  ASSERT_EQ(p.ss.size(), 5u);
  EXPECT_DOUBLE_EQ(p.ss[0], -305.5608);
  EXPECT_DOUBLE_EQ(p.ss[4], 5.302177e-9);
  ASSERT_EQ(p.invpol.size(), 8u);
  EXPECT_DOUBLE_EQ(p.invpol[7], -18.561481);
  EXPECT_DOUBLE_EQ(p.center_row, 213.92656);
  EXPECT_DOUBLE_EQ(p.center_col, 347.584904);
  EXPECT_DOUBLE_EQ(p.c, 1.002352);
  EXPECT_DOUBLE_EQ(p.d, 0.000113);
  EXPECT_DOUBLE_EQ(p.e, -0.001526);
  EXPECT_EQ(cam.width(), 640);
  EXPECT_EQ(cam.height(), 480);
  EXPECT_NEAR(cam.focalPx(), 305.5608, 1e-9);
}

TEST(OcamCalibFile, WriteReproducesRomoviFileByteForByte) {
  OVO_REQUIRE_DATA(kRomovi);
  const auto out = test::tempDir() / "calib_results.txt";
  writeOcamCalib(out, readOcamCalib(test::sharedData(kRomovi)));
  EXPECT_EQ(slurp(out), slurp(test::sharedData(kRomovi)));
}

TEST(OcamCalibFile, WriteReadRoundTripKeepsEveryValue) {
  for (const char* rel : {kSampleFisheye, kSampleCatadioptric}) {
    OVO_REQUIRE_DATA(rel);
    const OcamCamera a = readOcamCalib(test::sharedData(rel));
    const auto out = test::tempDir() / "calib.txt";
    writeOcamCalib(out, a);
    const OcamCamera b = readOcamCalib(out);
    EXPECT_EQ(a.params().ss, b.params().ss) << rel;
    EXPECT_EQ(a.params().invpol, b.params().invpol) << rel;
    EXPECT_EQ(a.params().center_row, b.params().center_row);
    EXPECT_EQ(a.params().center_col, b.params().center_col);
    EXPECT_EQ(a.params().c, b.params().c);
    EXPECT_EQ(a.params().d, b.params().d);
    EXPECT_EQ(a.params().e, b.params().e);
    EXPECT_EQ(a.width(), b.width());
    EXPECT_EQ(a.height(), b.height());
  }
}

TEST(OcamCalibFile, AByteOrderMarkAndWindowsLineEndsAreRead) {
  // Saved by a Windows editor: "calib_results.txt:1: '\xEF\xBB\xBF#polynomial' is not a number".
  const std::filesystem::path original = test::sourcePath("configs/cameras/romovi_ocam.txt");
  std::string text = "\xEF\xBB\xBF";
  for (char ch : slurp(original)) {
    if (ch == '\n') text += '\r';
    text += ch;
  }
  const auto copy = test::tempDir() / "calib_results.txt";
  test::writeTextFile(copy, text);
  const OcamParams a = readOcamCalib(original).params(), b = readOcamCalib(copy).params();
  EXPECT_EQ(a.ss, b.ss);
  EXPECT_EQ(a.invpol, b.invpol);
  EXPECT_EQ(a.center_row, b.center_row);
  EXPECT_EQ(a.c, b.c);
  EXPECT_TRUE(std::holds_alternative<OcamCamera>(loadCamera(copy)));
}

TEST(OcamCalibFile, FullPrecisionValuesSurviveWriteAndRead) {
  OcamParams p;
  p.ss = {-300.123456789012, 0.0, 1.23456789012345e-3, -1.1e-6, 4.4e-9};
  p.center_row = 240.123456789;
  p.center_col = 320.987654321;
  p.c = 1.0012345678;
  p.d = 1.5e-4;
  p.e = -1.25e-3;
  p.width = 640;
  p.height = 480;
  const OcamCamera a(p);  // no invpol: fitted
  const auto out = test::tempDir() / "calib.txt";
  writeOcamCalib(out, a);
  const OcamCamera b = readOcamCalib(out);
  EXPECT_EQ(b.params().ss, p.ss);
  EXPECT_EQ(b.params().center_row, p.center_row);
  EXPECT_EQ(b.params().c, p.c);
  EXPECT_EQ(b.params().invpol, a.projectionInvpol());
  EXPECT_LT(b.roundTrip().max_px, 0.01);
}

// Each malformed file must give an ovo::Error naming the file and the line.
void expectFileError(const std::string& content, long line, const std::string& what) {
  const auto file = test::tempDir() / "bad_calib.txt";
  std::ofstream(file) << content;
  try {
    readOcamCalib(file);
    ADD_FAILURE() << "no error for: " << what;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file.string() + ":" + std::to_string(line) + ":"), std::string::npos)
        << what << ": " << msg;
  }
}

std::string goodFile() {
  return "#ss\n\n5 -3.055608e+02 0.000000e+00 1.292850e-03 -1.425431e-06 5.302177e-09 \n\n"
         "#invpol\n\n8 429.030106 210.073626 -47.103376 -69.021889 -208.158118 -229.001725 "
         "-107.244699 -18.561481 \n\n#center\n\n213.926560 347.584904\n\n#affine\n\n"
         "1.002352 0.000113 -0.001526\n\n#size\n\n480 640\n";
}

std::string replaceLine(std::string text, int line, const std::string& with) {
  std::istringstream in(text);
  std::string out, l;
  for (int n = 1; std::getline(in, l); ++n) out += (n == line ? with : l) + "\n";
  return out;
}

TEST(OcamCalibFile, MalformedFilesNameFileAndLine) {
  ASSERT_NO_THROW({
    const auto file = test::tempDir() / "good.txt";
    std::ofstream(file) << goodFile();
    readOcamCalib(file);
  });
  expectFileError(replaceLine(goodFile(), 3, "5 -3.0e+02 0 abc 1 2"), 3, "non-numeric");
  expectFileError(replaceLine(goodFile(), 3, "5 -3.0e+02 0 1e-3 2e-6"), 3, "wrong count");
  expectFileError(replaceLine(goodFile(), 3, "3 -3.0e+02 nan 1e-3"), 3, "NaN");
  expectFileError(replaceLine(goodFile(), 3, "3 3.0e+02 0 1e-3"), 3, "a0 >= 0");
  expectFileError(replaceLine(goodFile(), 7, "2.5 1 2"), 7, "fractional count");
  expectFileError(replaceLine(goodFile(), 11, "213.9"), 11, "centre with one value");
  // A centre off the image: every ray then misses it (0 keyframes, silently, before).
  expectFileError(replaceLine(goodFile(), 11, "-50000 90000"), 11, "centre off the image");
  expectFileError(replaceLine(goodFile(), 11, "213.9 640"), 11, "centre column = width");
  expectFileError(replaceLine(goodFile(), 15, "1 1 1"), 15, "singular affine");
  expectFileError(replaceLine(goodFile(), 19, "480 -640"), 19, "negative width");
  // Truncated after the affine line (line 16): the error points past the last data line.
  std::string truncated = goodFile().substr(0, goodFile().find("\n#size"));
  expectFileError(truncated, 16, "truncated");
  expectFileError(goodFile() + "1 2 3\n", 20, "extra data");
  try {
    readOcamCalib(test::tempDir() / "missing.txt");
    ADD_FAILURE() << "no error for a missing file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.txt"), std::string::npos);
  }
}

// The class against DESIGN section 3's formulas on the real calibration (non-trivial c, d, e):
// ovo (x, y, z) = OCamCalib (col-component, row-component, -z').
TEST(OcamModel, MatchesToolboxFormulasInOvoAxes) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi), {.refit_invpol = false});
  const OcamParams& p = cam.params();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 639), v(0, 479);
  for (int i = 0; i < 500; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double pv = v(rng), pu = u(rng);
    const Vec2 px(pu, pv);
    if (!cam.isValid(px)) continue;
    const Vec3 b_ocam = toolboxCam2World(p, px.y(), px.x());
    const Vec3 b_C = *cam.unproject(px);
    EXPECT_LT((b_C - Vec3(b_ocam.y(), b_ocam.x(), -b_ocam.z())).norm(), 1e-12);
    const Vec2 rc = toolboxWorld2Cam(p, p.invpol, b_ocam);
    const Vec2 uv = *cam.project(b_C);
    EXPECT_LT((uv - Vec2(rc.y(), rc.x())).norm(), 1e-9);
  }
}

// libviso2's omnidirectional port swapped (row, col) of the centre and took z' < 0 as "in front":
// each assertion below fails under either mistake.
TEST(OcamSigns, CentreAndAxesHaveOvoOrientation) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi));
  const Vec2 centre(347.584904, 213.92656);  // (u = col, v = row)
  const Vec2 principal = *cam.project(Vec3(0, 0, 1));
  EXPECT_LT((principal - centre).norm(), 0.01);
  const Vec3 b_centre = *cam.unproject(centre);
  EXPECT_GT(b_centre.z(), 0.999999);
  const Vec3 b_right = *cam.unproject(centre + Vec2(100, 0));
  EXPECT_GT(b_right.x(), 0.25);
  EXPECT_LT(std::abs(b_right.y()), 0.01);
  EXPECT_GT(b_right.z(), 0.0);
  const Vec3 b_below = *cam.unproject(centre + Vec2(0, 100));
  EXPECT_GT(b_below.y(), 0.25);
  EXPECT_LT(std::abs(b_below.x()), 0.01);
  const Vec3 b_left_up = *cam.unproject(centre + Vec2(-150, -150));
  EXPECT_LT(b_left_up.x(), 0.0);
  EXPECT_LT(b_left_up.y(), 0.0);
  // A point ahead, to the right and below lands right of and below the centre.
  const Vec2 px = *cam.project(Vec3(1.0, 0.5, 3.0));
  EXPECT_GT(px.x(), centre.x() + 50);
  EXPECT_GT(px.y(), centre.y() + 25);
}

std::vector<Vec3> pointsAhead(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-4.0, 4.0), depth(2.0, 12.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double z = depth(rng), y = lateral(rng), x = lateral(rng);
    pts.emplace_back(x, 0.5 * y, z);
  }
  return pts;
}

TEST(OcamSigns, YawLeftMovesImageContentRight) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi));
  // Yaw left: the camera turns about its up axis (-y) by +5 degrees; its forward axis turns to -x.
  const Mat3 R_C1_C2 = Eigen::AngleAxisd(5.0 * std::numbers::pi / 180, -Vec3::UnitY()).matrix();
  ASSERT_LT((R_C1_C2 * Vec3::UnitZ()).x(), 0.0);
  int moved_right = 0, total = 0;
  double mean_du = 0.0;
  for (const Vec3& p_C1 : pointsAhead(300, 1)) {
    const Vec3 p_C2 = R_C1_C2.transpose() * p_C1;
    const auto a = cam.project(p_C1), b = cam.project(p_C2);
    if (!a || !b || !cam.isValid(*a) || !cam.isValid(*b)) continue;
    ++total;
    moved_right += (b->x() > a->x());
    mean_du += b->x() - a->x();
  }
  ASSERT_GT(total, 200);
  EXPECT_EQ(moved_right, total);
  // About focal x angle near the centre: 305 px/rad x 0.087 rad = 27 px.
  EXPECT_GT(mean_du / total, 15.0);
}

TEST(OcamSigns, ForwardMotionMovesPointsAwayFromPrincipalPoint) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi));
  const Vec2 principal = *cam.project(Vec3(0, 0, 1));
  const Vec3 t_C1_C2(0, 0, 1.0);  // 1 m forward along +z
  int outward = 0, total = 0;
  for (const Vec3& p_C1 : pointsAhead(300, 2)) {
    const Vec3 p_C2 = p_C1 - t_C1_C2;
    const auto a = cam.project(p_C1), b = cam.project(p_C2);
    if (!a || !b || !cam.isValid(*a) || !cam.isValid(*b)) continue;
    ++total;
    outward += ((*b - principal).norm() > (*a - principal).norm());
  }
  ASSERT_GT(total, 200);
  EXPECT_EQ(outward, total);
}

void expectProjectJacobian(const OcamCamera& cam, const Vec3& p) {
  Eigen::Matrix<double, 2, 3> J;
  const auto px = cam.project(p, &J);
  ASSERT_TRUE(px) << p.transpose();
  const Eigen::MatrixXd J_num = test::numericJacobian(
      [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return *cam.project(Vec3(x)); }, p);
  OVO_EXPECT_JACOBIAN_NEAR(J, J_num, 1e-6);
}

TEST(OcamModel, ProjectJacobianMatchesNumericIncludingBeyond90Degrees) {
  for (const char* rel : {kRomovi, kSampleFisheye, kSampleCatadioptric}) {
    OVO_REQUIRE_DATA(rel);
    const OcamCamera cam = readOcamCalib(test::sharedData(rel));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> azimuth(-std::numbers::pi, std::numbers::pi);
    std::uniform_real_distribution<double> off_axis(0.0, cam.maxOffAxisRad() - 1e-3);
    std::uniform_real_distribution<double> range(0.5, 20.0);
    int beyond_90 = 0;
    for (int i = 0; i < 300; ++i) {
      const double a = azimuth(rng), phi = off_axis(rng);
      const Vec3 p = range(rng) *
                     Vec3(std::sin(phi) * std::cos(a), std::sin(phi) * std::sin(a), std::cos(phi));
      beyond_90 += p.z() < 0.0;
      SCOPED_TRACE(std::string(rel) + " point " + std::to_string(i));
      expectProjectJacobian(cam, p);
    }
    // Near the optical axis (the limit formula) and just off it.
    expectProjectJacobian(cam, Vec3(0, 0, 2));
    expectProjectJacobian(cam, Vec3(1e-4, -2e-4, 2));
    if (cam.maxOffAxisRad() > std::numbers::pi / 2 + 0.2) {
      EXPECT_GT(beyond_90, 10) << rel;
    }
  }
}

TEST(OcamModel, ProjectRefusesRaysBeyondTheCalibratedFieldOfView) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamCamera cam = readOcamCalib(test::sharedData(kRomovi));
  EXPECT_FALSE(cam.project(Vec3(0, 0, -1)).has_value());
  EXPECT_FALSE(cam.project(Vec3::Zero()).has_value());
  const double phi = cam.maxOffAxisRad() + 0.01;
  EXPECT_FALSE(cam.project(Vec3(std::sin(phi), 0, std::cos(phi))).has_value());
  EXPECT_FALSE(cam.unproject(Vec2(5000, 5000)).has_value());
}

// Round trip |project(unproject(px)) - px| over every valid pixel, with the file's invpol and
// with the model's (refit when the file's reaches 0.01 px).
TEST(OcamRoundTrip, BelowOneHundredthPixelOverEveryValidPixel) {
  for (const char* rel : {kRomovi, kSampleFisheye, kSampleCatadioptric}) {
    OVO_REQUIRE_DATA(rel);
    const OcamCamera file_cam = readOcamCalib(test::sharedData(rel), {.refit_invpol = false});
    const OcamCamera cam = readOcamCalib(test::sharedData(rel));
    const PixelRoundTrip before = pixelRoundTrip(file_cam);
    const PixelRoundTrip after = pixelRoundTrip(cam);
    std::printf(
        "[round trip] %s: valid radius %.1f px, max off-axis %.1f deg, %ld valid pixels; file "
        "invpol (%zu coeffs) max %.4f mean %.4f px; %s (%zu coeffs) max %.5f mean %.5f px\n",
        rel, cam.maxRadiusPx(), cam.maxOffAxisRad() * 180 / std::numbers::pi, after.pixels,
        cam.params().invpol.size(), before.max_px, before.mean_px,
        cam.invpolRefit() ? "refit" : "kept", cam.projectionInvpol().size(), after.max_px,
        after.mean_px);
    EXPECT_EQ(after.failures, 0) << rel;
    EXPECT_GT(after.pixels, 0.5 * cam.width() * cam.height()) << rel;
    EXPECT_LT(after.max_px, 0.01) << rel;
    if (before.max_px >= 0.01) {
      EXPECT_TRUE(cam.invpolRefit()) << rel;
    }
  }
}

TEST(OcamRoundTrip, FittedInvpolMapsTheAxisToTheCentre) {
  OVO_REQUIRE_DATA(kRomovi);
  const OcamParams p = readOcamCalib(test::sharedData(kRomovi)).params();
  const auto invpol = fitInvpol(p.ss, 400.0, 10);
  EXPECT_NEAR(polyval(invpol, -std::numbers::pi / 2), 0.0, 1e-9);
}

}  // namespace
}  // namespace ovo::camera
