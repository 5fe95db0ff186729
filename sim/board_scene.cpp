#include "sim/board_scene.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "common/config.hpp"
#include "common/error.hpp"
#include "sim/random.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr std::uint64_t kPoseStream = 0xb0a4d;
constexpr std::uint64_t kPixelStream = 0x91e1;

// The camera file as given, from the current folder, or beside the config file and its parents.
std::string resolveCalibration(const Config& c, const std::string& value) {
  namespace fs = std::filesystem;
  const fs::path p(value);
  if (fs::exists(p)) return fs::absolute(p).string();
  fs::path dir = fs::absolute(fs::path(c.source())).parent_path();
  for (int i = 0; i < 8 && !p.is_absolute() && !dir.empty(); ++i) {
    if (fs::exists(dir / p)) return fs::weakly_canonical(dir / p).string();
    if (dir == dir.parent_path()) break;
    dir = dir.parent_path();
  }
  fail(
      "{}: key 'camera.calibration': file '{}' not found (looked in the current folder and "
      "beside {})",
      c.location("camera.calibration"), value, c.source());
}

// The board's outline (squares plus margin) in the board frame, sampled along its edges.
std::vector<Vec3> outline(const BoardSceneOptions& o) {
  const double x0 = -o.square_m - o.margin_m, x1 = o.cols * o.square_m + o.margin_m;
  const double y0 = -o.square_m - o.margin_m, y1 = o.rows * o.square_m + o.margin_m;
  std::vector<Vec3> pts;
  for (int i = 0; i <= 8; ++i) {
    const double f = i / 8.0;
    pts.emplace_back(x0 + f * (x1 - x0), y0, 0.0);
    pts.emplace_back(x0 + f * (x1 - x0), y1, 0.0);
    pts.emplace_back(x0, y0 + f * (y1 - y0), 0.0);
    pts.emplace_back(x1, y0 + f * (y1 - y0), 0.0);
  }
  return pts;
}

Mat3 rotationAbout(const Vec3& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

}  // namespace

bool isBoardScene(const Config& config) {
  return config.getChoice("scene", "vineyard", {"vineyard", "checkerboard"}) == "checkerboard";
}

BoardSceneOptions readBoardScene(const Config& c) {
  BoardSceneOptions o;
  c.getChoice("scene", "checkerboard", {"checkerboard"});
  c.get<std::string>("name", "");
  o.calibration = resolveCalibration(
      c, c.get<std::string>("camera.calibration", "configs/cameras/romovi_ocam.txt"));
  o.seed = static_cast<std::uint64_t>(c.getInt64InRange("seed", 1, 0, INT64_MAX - 1));
  o.cols = c.getIntInRange("board.cols", o.cols, 2, 40);
  o.rows = c.getIntInRange("board.rows", o.rows, 2, 40);
  o.square_m = c.getInRange("board.square_m", o.square_m, 0.001, 1.0);
  o.margin_m = c.getInRange("board.margin_m", o.margin_m, 0.0, 1.0);
  o.views = c.getIntInRange("board.views", o.views, 1, 1000);
  o.min_distance_m = c.getInRange("board.min_distance_m", o.min_distance_m, 0.05, 100.0);
  o.max_distance_m = c.getInRange("board.max_distance_m", o.max_distance_m, 0.05, 100.0);
  if (o.max_distance_m < o.min_distance_m)
    fail("{}: board.max_distance_m must not be below board.min_distance_m",
         c.location("board.max_distance_m"));
  o.max_off_axis_deg = c.getInRange("board.max_off_axis_deg", o.max_off_axis_deg, 0.0, 180.0);
  o.max_tilt_deg = c.getInRange("board.max_tilt_deg", o.max_tilt_deg, 0.0, 80.0);
  o.supersample = c.getIntInRange("render.supersample", o.supersample, 1, 8);
  o.noise_sigma = c.getInRange("nuisance.noise_sigma", o.noise_sigma, 0.0, 50.0);
  o.black = c.getInRange("board.black", o.black, 0.0, 255.0);
  o.white = c.getInRange("board.white", o.white, 0.0, 255.0);
  o.background = c.getInRange("board.background", o.background, 0.0, 255.0);
  c.checkAllUsed();
  return o;
}

std::vector<BoardView> boardViews(const camera::Camera& cam, const BoardSceneOptions& o) {
  Rng rng(subSeed(o.seed, kPoseStream));
  const Vec3 centre_B(0.5 * (o.cols - 1) * o.square_m, 0.5 * (o.rows - 1) * o.square_m, 0.0);
  const std::vector<Vec3> edge = outline(o);
  std::vector<BoardView> views;
  const double cos_max = std::cos(o.max_off_axis_deg * kDeg);
  for (int attempt = 0; static_cast<int>(views.size()) < o.views && attempt < 20000; ++attempt) {
    // Centre direction uniform over the solid angle up to max_off_axis.
    const double cos_off = 1.0 - rng.uniform() * (1.0 - cos_max);
    const double off = std::acos(cos_off), azim = rng.uniform(0.0, 2.0 * M_PI);
    const Vec3 dir(std::sin(off) * std::cos(azim), std::sin(off) * std::sin(azim), cos_off);
    const double dist = rng.uniform(o.min_distance_m, o.max_distance_m);
    // Board normal (z_B, pointing away from the camera) tilted from the line of sight, and the
    // board turned about it by any angle.
    const double tz = rng.uniform(-1, 1);  // one draw a statement (sim/random.hpp)
    const double ty = rng.uniform(-1, 1);
    const double tx = rng.uniform(-1, 1);
    const Vec3 tilt_axis = dir.cross(Vec3(tx, ty, tz));
    if (tilt_axis.norm() < 1e-6) continue;
    const Vec3 z_B = rotationAbout(tilt_axis, rng.uniform(0.0, o.max_tilt_deg * kDeg)) * dir;
    Vec3 x_B = z_B.unitOrthogonal();
    x_B = rotationAbout(z_B, rng.uniform(0.0, 2.0 * M_PI)) * x_B;
    BoardView view;
    Mat3 R;
    R << x_B, z_B.cross(x_B), z_B;
    view.T_C_B.linear() = R;
    view.T_C_B.translation() = dist * dir - R * centre_B;
    bool ok = true;
    for (const Vec3& p : edge) {
      const auto px = camera::project(cam, view.T_C_B * p);
      if (!px || !camera::isValid(cam, *px)) {
        ok = false;
        break;
      }
    }
    for (int k = 0; ok && k < o.cols * o.rows; ++k) {
      const Vec3 p((k % o.cols) * o.square_m, (k / o.cols) * o.square_m, 0.0);
      const auto px = camera::project(cam, view.T_C_B * p);
      // A few pixels inside the valid area, so the detector's windows stay in the image.
      bool inside = px.has_value();
      for (const Vec2& d : {Vec2(4, 0), Vec2(-4, 0), Vec2(0, 4), Vec2(0, -4)})
        inside = inside && camera::isValid(cam, *px + d);
      if (!inside)
        ok = false;
      else
        view.corners_px.push_back(*px);
    }
    if (ok) views.push_back(std::move(view));
  }
  if (static_cast<int>(views.size()) < o.views)
    fail(
        "board scene: only {} of {} board views fit in the image; lower board.max_off_axis_deg "
        "or board.min_distance_m, or use a smaller board",
        views.size(), o.views);
  return views;
}

cv::Mat renderBoardView(const camera::Camera& cam, const BoardSceneOptions& o,
                        const BoardView& view, int k) {
  const int W = camera::width(cam), H = camera::height(cam);
  cv::Mat image(H, W, CV_8U, cv::Scalar(0));
  const SE3 T_B_C = view.T_C_B.inverse();
  const Mat3 R_B_C = T_B_C.linear();
  const Vec3 o_B = T_B_C.translation();
  const double x0 = -o.square_m - o.margin_m, x1 = o.cols * o.square_m + o.margin_m;
  const double y0 = -o.square_m - o.margin_m, y1 = o.rows * o.square_m + o.margin_m;
  const int ss = o.supersample;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      std::uint8_t* out = image.ptr<std::uint8_t>(v);
      // One stream a row: the bytes do not depend on the threads.
      Rng rng(subSeed(o.seed, kPixelStream ^ (static_cast<std::uint64_t>(k) << 20) ^
                                  static_cast<std::uint64_t>(v)));
      for (int u = 0; u < W; ++u) {
        if (!camera::isValid(cam, Vec2(u, v))) continue;
        double sum = 0.0;
        int n = 0;
        for (int sy = 0; sy < ss; ++sy)
          for (int sx = 0; sx < ss; ++sx) {
            // Jittered samples: the expected value is the pixel's box-filtered radiance.
            const double jitter_v = rng.uniform();  // one draw a statement (sim/random.hpp)
            const double jitter_u = rng.uniform();
            const Vec2 sub(u - 0.5 + (sx + jitter_u) / ss, v - 0.5 + (sy + jitter_v) / ss);
            const auto b = camera::unproject(cam, sub);
            if (!b) continue;
            ++n;
            const Vec3 d = R_B_C * *b;
            // A faint gradient behind the board, nothing corner-like.
            double value = o.background + 20.0 * b->y();
            if (d.z() * o_B.z() < 0.0) {  // the ray reaches the board's plane
              const double lambda = -o_B.z() / d.z();
              const double X = o_B.x() + lambda * d.x(), Y = o_B.y() + lambda * d.y();
              if (X >= x0 && X <= x1 && Y >= y0 && Y <= y1) {
                value = o.white;
                const int i = static_cast<int>(std::floor(X / o.square_m));
                const int j = static_cast<int>(std::floor(Y / o.square_m));
                if (i >= -1 && i < o.cols && j >= -1 && j < o.rows && ((i + j) & 1) == 0)
                  value = o.black;
              }
            }
            sum += value;
          }
        if (n == 0) continue;
        const double g = sum / n + o.noise_sigma * rng.normal();
        out[u] = static_cast<std::uint8_t>(std::clamp(std::lround(g), 0L, 255L));
      }
    }
  });
  return image;
}

std::string boardSceneYaml(const BoardSceneOptions& o) {
  return fmt::format(
      "# Effective board scene (ovo simulate, scene: checkerboard). Board frame: inner corner (i, "
      "j) at (i, j) * square_m, z = 0.\nscene: checkerboard\nseed: {}\ncamera:\n  calibration: "
      "\"{}\"\nboard:\n  cols: {}\n  rows: {}\n  square_m: {}\n  margin_m: {}\n  views: {}\n"
      "  min_distance_m: {}\n  max_distance_m: {}\n  max_off_axis_deg: {}\n  max_tilt_deg: {}\n"
      "  black: {}\n  white: {}\n  background: {}\nrender:\n  supersample: {}\nnuisance:\n"
      "  noise_sigma: {}\n",
      o.seed, o.calibration, o.cols, o.rows, o.square_m, o.margin_m, o.views, o.min_distance_m,
      o.max_distance_m, o.max_off_axis_deg, o.max_tilt_deg, o.black, o.white, o.background,
      o.supersample, o.noise_sigma);
}

}  // namespace ovo::sim
