// Helpers of the calibration tests: synthetic board views of a known camera, the RoMoVi model,
// and the peer tool's (py-OCamCalib's) fish_1 calibration in ovo's conventions.
#pragma once

#include <random>
#include <vector>

#include "calib/board.hpp"
#include "calib/ocam_linear_init.hpp"
#include "camera/calib_io.hpp"
#include "camera/camera.hpp"
#include "tests/test_support.hpp"

namespace ovo::calib::test {

inline camera::Camera romoviCamera() {
  return camera::loadCamera(ovo::test::sourcePath("configs/cameras/romovi_ocam.txt"));
}

/// Views of a board whose centre lies at off-axis angles spread over the field of view, each
/// seen through `cam` (corners outside the valid image dropped; views with fewer than all
/// corners left out), with Gaussian pixel noise.
inline std::vector<BoardObservation> syntheticBoards(const camera::Camera& cam,
                                                     const BoardSpec& spec, int views,
                                                     double max_off_axis_deg, double noise_px,
                                                     unsigned seed,
                                                     std::vector<BoardPose>* truth = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  // Unit noise scaled by noise_px (0: exact corners; a normal_distribution needs a sigma > 0).
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<BoardObservation> out;
  const Vec3 board_centre(0.5 * (spec.cols - 1) * spec.square_m,
                          0.5 * (spec.rows - 1) * spec.square_m, 0.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int attempt = 0; static_cast<int>(out.size()) < views && attempt < 200 * views; ++attempt) {
    // Off-axis angles spread evenly over the solid angle, the first view on the axis.
    const double off =
        out.empty()
            ? 0.0
            : std::acos(1.0 - unit(rng) * (1.0 - std::cos(max_off_axis_deg * M_PI / 180.0)));
    const double azim = 2.0 * M_PI * unit(rng);
    const Vec3 dir(std::sin(off) * std::cos(azim), std::sin(off) * std::sin(azim), std::cos(off));
    const double dist = 0.35 + 0.15 * (uni(rng) + 1.0);
    // Board facing the camera, tilted by up to 40 deg and turned about its normal.
    const Vec3 normal = (-dir + 0.5 * ovo::test::draw3(uni, rng)).normalized();
    const double roll = M_PI * uni(rng);  // the board turned about its normal, any way
    Vec3 a = normal.cross(Vec3(std::cos(roll), std::sin(roll), 0.2)).normalized();
    Vec3 b = normal.cross(a);
    BoardPose pose;
    pose.R_C_B.col(0) = a;
    pose.R_C_B.col(1) = b;
    pose.R_C_B.col(2) = a.cross(b);
    pose.t_C_B = dist * dir - pose.R_C_B * board_centre;
    BoardObservation obs;
    obs.image = "view_" + std::to_string(out.size());
    obs.width = camera::width(cam);
    obs.height = camera::height(cam);
    bool all = true;
    for (int i = 0; i < spec.cornerCount(); ++i) {
      const Vec3 p_C = pose.R_C_B * spec.point(i) + pose.t_C_B;
      const auto px = camera::project(cam, p_C);
      if (!px || !camera::isValid(cam, *px)) {
        all = false;
        break;
      }
      obs.corners_px.push_back(*px + noise_px * ovo::test::draw2(gauss, rng));
      obs.points_B.push_back(spec.point(i));
    }
    if (!all) continue;
    out.push_back(std::move(obs));
    if (truth) truth->push_back(pose);
  }
  return out;
}

/// py-OCamCalib's fish_1 calibration (pyocamcalib_calibration_fisheye_1_18052022_154907.json) in
/// the toolbox's conventions. Its model: (col, row) - centre = S (x, y), S = [[c, d], [e, 1]],
/// bearing ~ (x, y, taylor(rho)) with z forward. The toolbox's: [row; col] = [c' d'; e' 1] (x',
/// y') with x' = c y, y' = c x, so c' = 1 / c, d' = e / c, e' = d / c and ss(rho') = -c
/// taylor(rho' / c): a'_k = -a_k c^(1 - k).
inline camera::OcamParams peerFish1Params() {
  const double taylor[5] = {337.71684227978966, 0.0, -0.0012238320710672823, 1.3803997515890267e-06,
                            -3.0106166073815756e-09};
  const double cx = 543.9861511428039, cy = 377.64882547339226;
  const double c = 1.0032962305648117, d = 0.00014800947722706114, e = 0.00017686046028285402;
  camera::OcamParams p;
  for (int k = 0; k < 5; ++k) p.ss.push_back(-taylor[k] * std::pow(c, 1 - k));
  p.center_row = cy;
  p.center_col = cx;
  p.c = 1.0 / c;
  p.d = e / c;
  p.e = d / c;
  p.width = 1032;
  p.height = 778;
  return p;
}

constexpr double kPeerFish1MeanOfMeansPx = 0.24125227245668737;  // its "rms_overall"

}  // namespace ovo::calib::test
