// Camera model costs: project (with and without the Jacobian) and unproject per model, over a
// fixed set of image points / rays. BM_CameraProject/<model>, BM_CameraProjectPoint/<model>,
// BM_CameraUnproject/<model>.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>
#include <vector>

#include "camera/calib_io.hpp"

namespace {

using ovo::Vec2;
using ovo::Vec3;
namespace cam = ovo::camera;

cam::Camera romoviOrSynthetic() {
  const std::filesystem::path file =
      std::filesystem::path(OVO_SHARED_DATA_DIR) / "romovi-fisheye-calib/calib_results.txt";
  if (std::filesystem::exists(file)) return cam::readOcamCalib(file);
  cam::OcamParams p;  // the RoMoVi numbers, invpol fitted
  p.ss = {-305.5608, 0.0, 1.29285e-3, -1.425431e-6, 5.302177e-9};
  p.center_row = 213.92656;
  p.center_col = 347.584904;
  p.c = 1.002352;
  p.d = 0.000113;
  p.e = -0.001526;
  p.width = 640;
  p.height = 480;
  return cam::OcamCamera(p);
}

cam::Camera makeModel(const std::string& name) {
  if (name == "ocam") return romoviOrSynthetic();
  if (name == "kannala_brandt")
    return cam::KannalaBrandtCamera({.fx = 190.98,
                                     .fy = 190.97,
                                     .cx = 254.93,
                                     .cy = 256.90,
                                     .k1 = 0.00348,
                                     .k2 = 0.000715,
                                     .k3 = -0.00205,
                                     .k4 = 0.000203,
                                     .width = 512,
                                     .height = 512});
  return cam::PinholeRadtanCamera({.fx = 458.654,
                                   .fy = 457.296,
                                   .cx = 367.215,
                                   .cy = 248.375,
                                   .k1 = -0.28340811,
                                   .k2 = 0.07395907,
                                   .p1 = 0.00019359,
                                   .p2 = 1.76187114e-05,
                                   .k3 = 0.0,
                                   .width = 752,
                                   .height = 480});
}

std::vector<Vec2> validPixels(const cam::Camera& c, int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, cam::width(c) - 1), v(0, cam::height(c) - 1);
  std::vector<Vec2> out;
  while (static_cast<int>(out.size()) < n) {
    const double pv = v(rng),
                 pu = u(rng);  // one draw a statement: a call's arguments have no fixed order
    const Vec2 px(pu, pv);
    if (cam::isValid(c, px)) out.push_back(px);
  }
  return out;
}

template <typename Model>
void projectLoop(benchmark::State& state, const Model& model, const std::vector<Vec3>& rays,
                 bool jacobian) {
  Eigen::Matrix<double, 2, 3> J;
  Eigen::Matrix<double, 2, 3>* want = jacobian ? &J : nullptr;
  for (auto _ : state)
    for (const Vec3& r : rays) benchmark::DoNotOptimize(model.project(r, want));
  state.SetItemsProcessed(state.iterations() * rays.size());
}

template <typename Model>
void unprojectLoop(benchmark::State& state, const Model& model, const std::vector<Vec2>& pixels) {
  for (auto _ : state)
    for (const Vec2& px : pixels) benchmark::DoNotOptimize(model.unproject(px));
  state.SetItemsProcessed(state.iterations() * pixels.size());
}

void projectBench(benchmark::State& state, const std::string& name, bool jacobian) {
  const cam::Camera c = makeModel(name);
  std::vector<Vec3> rays;
  for (const Vec2& px : validPixels(c, 1000)) rays.push_back(3.0 * *cam::unproject(c, px));
  std::visit([&](const auto& model) { projectLoop(state, model, rays, jacobian); }, c);
}

void BM_CameraProject(benchmark::State& state, const std::string& name) {
  projectBench(state, name, true);
}

// Without the Jacobian: the frontend's rotation prediction of every feature.
void BM_CameraProjectPoint(benchmark::State& state, const std::string& name) {
  projectBench(state, name, false);
}

void BM_CameraUnproject(benchmark::State& state, const std::string& name) {
  const cam::Camera c = makeModel(name);
  const auto pixels = validPixels(c, 1000);
  std::visit([&](const auto& model) { unprojectLoop(state, model, pixels); }, c);
}

BENCHMARK_CAPTURE(BM_CameraProject, ocam, std::string("ocam"));
BENCHMARK_CAPTURE(BM_CameraProject, kannala_brandt, std::string("kannala_brandt"));
BENCHMARK_CAPTURE(BM_CameraProject, pinhole_radtan, std::string("pinhole_radtan"));
BENCHMARK_CAPTURE(BM_CameraProjectPoint, ocam, std::string("ocam"));
BENCHMARK_CAPTURE(BM_CameraProjectPoint, kannala_brandt, std::string("kannala_brandt"));
BENCHMARK_CAPTURE(BM_CameraProjectPoint, pinhole_radtan, std::string("pinhole_radtan"));
BENCHMARK_CAPTURE(BM_CameraUnproject, ocam, std::string("ocam"));
BENCHMARK_CAPTURE(BM_CameraUnproject, kannala_brandt, std::string("kannala_brandt"));
BENCHMARK_CAPTURE(BM_CameraUnproject, pinhole_radtan, std::string("pinhole_radtan"));

}  // namespace
