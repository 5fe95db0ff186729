#include "calib/ocam_linear_init.hpp"

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/projection.hpp"
#include "common/so3.hpp"

namespace ovo::calib {
namespace {

// ovo's camera frame from the toolbox's axes (row, column, backwards): x = y', y = x', z = -z'.
Mat3 ovoFromToolbox() {
  Mat3 M;
  M << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return M;
}

// One board's extrinsics in the toolbox's axes, all but t3, from the equation free of the
// polynomial (IROS 2006 eq. 9: u (r21 X + r22 Y + t2) - v (r11 X + r12 Y + t1) = 0).
struct PartialPose {
  double r11, r12, r21, r22, r31, r32, t1, t2;
};

// (u, v) = (x', y') of each corner relative to the centre, the toolbox's axes.
std::vector<Vec2> centred(const BoardObservation& board, double center_row, double center_col) {
  std::vector<Vec2> out;
  out.reserve(board.size());
  for (const Vec2& px : board.corners_px)
    out.emplace_back(px.y() - center_row, px.x() - center_col);
  return out;
}

std::optional<PartialPose> partialPose(const BoardObservation& board, const std::vector<Vec2>& uv) {
  const int n = static_cast<int>(board.size());
  if (n < 6) return std::nullopt;
  Eigen::MatrixXd M(n, 6);
  for (int i = 0; i < n; ++i) {
    const double X = board.points_B[i].x(), Y = board.points_B[i].y();
    const double u = uv[i].x(), v = uv[i].y();
    M.row(i) << -v * X, -v * Y, u * X, u * Y, -v, u;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  const Eigen::VectorXd s = svd.singularValues();
  if (!(s(4) > 1e-9 * s(0))) return std::nullopt;  // a two-dimensional null space: degenerate
  Eigen::VectorXd h = svd.matrixV().col(5);
  // The corners' image directions point along the board points' (x', y'): lambda > 0.
  double dir = 0.0;
  for (int i = 0; i < n; ++i) {
    const double X = board.points_B[i].x(), Y = board.points_B[i].y();
    dir += uv[i].x() * (h(0) * X + h(1) * Y + h(4)) + uv[i].y() * (h(2) * X + h(3) * Y + h(5));
  }
  if (dir < 0.0) h = -h;
  PartialPose p{h(0), h(1), h(2), h(3), 0.0, 0.0, h(4), h(5)};
  // r31, r32 from |r1| = |r2| and r1 . r2 = 0: r31^2 - r32^2 = A, r31 r32 = B.
  const double A = (p.r12 * p.r12 + p.r22 * p.r22) - (p.r11 * p.r11 + p.r21 * p.r21);
  const double B = -(p.r11 * p.r12 + p.r21 * p.r22);
  const double q = 0.5 * (-A + std::sqrt(A * A + 4.0 * B * B));  // r32^2
  const double scale2 = p.r11 * p.r11 + p.r12 * p.r12 + p.r21 * p.r21 + p.r22 * p.r22;
  if (q > 1e-10 * scale2) {
    p.r32 = std::sqrt(q);
    p.r31 = B / p.r32;
  } else {
    p.r32 = 0.0;
    p.r31 = std::sqrt(std::max(A, 0.0));
  }
  const double lambda = std::sqrt(p.r11 * p.r11 + p.r21 * p.r21 + p.r31 * p.r31);
  if (!(lambda > 0.0)) return std::nullopt;
  for (double* v : {&p.r11, &p.r12, &p.r21, &p.r22, &p.r31, &p.r32, &p.t1, &p.t2}) *v /= lambda;
  return p;
}

// Appends the two rows of IROS 2006 eqs. 7-8 for one corner: with P = (C, A, B + t3) the board
// point in the toolbox's axes (B = r31 X + r32 Y) and p = (u, v, ss(rho)) the image point,
// p x P = 0 gives  -A ss + v t3 = -v B  and  C ss - u t3 = u B.
struct LinearRows {
  Eigen::MatrixXd M;
  Eigen::VectorXd b;
};

LinearRows boardRows(const BoardObservation& board, const std::vector<Vec2>& uv,
                     const PartialPose& p, int degree, double rho_scale) {
  const int n = static_cast<int>(board.size());
  const int nc = degree;  // a0, a2..aN
  LinearRows rows{Eigen::MatrixXd::Zero(2 * n, nc + 1), Eigen::VectorXd::Zero(2 * n)};
  for (int i = 0; i < n; ++i) {
    const double X = board.points_B[i].x(), Y = board.points_B[i].y();
    const double u = uv[i].x(), v = uv[i].y();
    const double C = p.r11 * X + p.r12 * Y + p.t1;
    const double A = p.r21 * X + p.r22 * Y + p.t2;
    const double B = p.r31 * X + p.r32 * Y;
    const double t = uv[i].norm() / rho_scale;
    double power = 1.0;
    for (int k = 0, col = 0; k <= degree; ++k, power *= t) {
      if (k == 1) continue;
      rows.M(2 * i, col) = -A * power;
      rows.M(2 * i + 1, col) = C * power;
      ++col;
    }
    rows.M(2 * i, nc) = v;
    rows.M(2 * i + 1, nc) = -u;
    rows.b(2 * i) = -v * B;
    rows.b(2 * i + 1) = u * B;
  }
  return rows;
}

// Least squares with columns scaled to unit norm (the depth and polynomial columns differ by
// orders of magnitude).
std::optional<Eigen::VectorXd> solveScaled(const Eigen::MatrixXd& M, const Eigen::VectorXd& b) {
  Eigen::VectorXd norms = M.colwise().norm().transpose();
  for (int j = 0; j < norms.size(); ++j)
    if (!(norms(j) > 0.0)) return std::nullopt;
  const Eigen::MatrixXd Ms = M * norms.cwiseInverse().asDiagonal();
  const auto qr = Ms.colPivHouseholderQr();
  if (qr.rank() < Ms.cols()) return std::nullopt;
  Eigen::VectorXd x = qr.solve(b);
  x = x.cwiseQuotient(norms);
  if (!x.allFinite()) return std::nullopt;
  return x;
}

}  // namespace

double ocamInitRms(const std::vector<BoardObservation>& boards, const OcamInit& init) {
  double b[kOcamMaxCoeffs] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t k = 0; k < init.ss.size() && k < kOcamMaxCoeffs; ++k) b[k] = init.ss[k];
  const double centre[2] = {init.center_row, init.center_col};
  const double affine[3] = {1.0, 0.0, 0.0};
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t j = 0; j < boards.size(); ++j) {
    const double rho_max = 2.0 * std::hypot(boards[j].width, boards[j].height);
    for (std::size_t i = 0; i < boards[j].size(); ++i, ++n) {
      const Vec3 p_C = init.poses[j].R_C_B * boards[j].points_B[i] + init.poses[j].t_C_B;
      double uv[2];
      double e2 = 100.0 * 100.0;
      if (projectOcam(b, 1.0, centre, affine, p_C.data(), rho_max, uv))
        e2 = std::min(e2, (Vec2(uv[0], uv[1]) - boards[j].corners_px[i]).squaredNorm());
      sum += e2;
    }
  }
  return n ? std::sqrt(sum / n) : std::numeric_limits<double>::infinity();
}

std::optional<OcamInit> ocamLinearEstimate(const std::vector<BoardObservation>& boards,
                                           double center_row, double center_col, int degree) {
  if (boards.empty() || degree < 2 || degree >= kOcamMaxCoeffs) return std::nullopt;
  const int K = static_cast<int>(boards.size());
  std::vector<std::vector<Vec2>> uv(K);
  std::vector<PartialPose> partial(K);
  double rho_scale = 0.0;
  for (int j = 0; j < K; ++j) {
    uv[j] = centred(boards[j], center_row, center_col);
    for (const Vec2& p : uv[j]) rho_scale = std::max(rho_scale, p.norm());
  }
  if (!(rho_scale > 0.0)) return std::nullopt;
  for (int j = 0; j < K; ++j) {
    const auto p = partialPose(boards[j], uv[j]);
    if (!p) return std::nullopt;
    partial[j] = *p;
    // The two roots of r31, r32 are mirror images (z' -> -z', ss -> -ss): keep the one whose
    // single-board quadratic fit has a0 < 0, the toolbox's sign (forward rays have z' < 0).
    const LinearRows rows = boardRows(boards[j], uv[j], partial[j], 2, rho_scale);
    const auto x = solveScaled(rows.M, rows.b);
    if (!x) return std::nullopt;
    if ((*x)(0) > 0.0) {
      partial[j].r31 = -partial[j].r31;
      partial[j].r32 = -partial[j].r32;
    }
  }
  // All boards at once: a0, a2..aN and each board's t3.
  int total_rows = 0;
  for (int j = 0; j < K; ++j) total_rows += 2 * static_cast<int>(boards[j].size());
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(total_rows, degree + K);
  Eigen::VectorXd b(total_rows);
  for (int j = 0, row = 0; j < K; ++j) {
    const LinearRows rows = boardRows(boards[j], uv[j], partial[j], degree, rho_scale);
    const int n = static_cast<int>(rows.M.rows());
    M.block(row, 0, n, degree) = rows.M.leftCols(degree);
    M.block(row, degree + j, n, 1) = rows.M.col(degree);
    b.segment(row, n) = rows.b;
    row += n;
  }
  const auto x = solveScaled(M, b);
  if (!x) return std::nullopt;
  OcamInit init;
  init.center_row = center_row;
  init.center_col = center_col;
  init.ss.assign(degree + 1, 0.0);
  for (int k = 0, col = 0; k <= degree; ++k) {
    if (k == 1) continue;
    init.ss[k] = (*x)(col++) / std::pow(rho_scale, k);
  }
  if (!(init.ss[0] < 0.0)) return std::nullopt;
  const Mat3 M_C_O = ovoFromToolbox();
  for (int j = 0; j < K; ++j) {
    const PartialPose& p = partial[j];
    const Vec3 r1(p.r11, p.r21, p.r31), r2(p.r12, p.r22, p.r32);
    Mat3 R_O;
    R_O << r1, r2, r1.cross(r2);
    BoardPose pose;
    pose.R_C_B = M_C_O * so3::orthonormalize(R_O);
    pose.t_C_B = M_C_O * Vec3(p.t1, p.t2, (*x)(degree + j));
    init.poses.push_back(pose);
  }
  init.rms_px = ocamInitRms(boards, init);
  return init;
}

std::optional<OcamInit> ocamLinearInit(const std::vector<BoardObservation>& boards,
                                       const OcamInitOptions& options, std::string* why) {
  if (boards.empty()) {
    if (why) *why = "no boards";
    return std::nullopt;
  }
  const double W = boards.front().width, H = boards.front().height;
  double best_row = 0.5 * (H - 1), best_col = 0.5 * (W - 1);
  double span_row = options.search_fraction * H, span_col = options.search_fraction * W;
  std::optional<OcamInit> best;
  const int g = std::max(1, options.grid);
  for (int level = 0; level < std::max(1, options.levels); ++level) {
    const double row0 = best_row, col0 = best_col;
    for (int a = 0; a < g; ++a) {
      for (int c = 0; c < g; ++c) {
        const double fr = g == 1 ? 0.0 : 2.0 * a / (g - 1) - 1.0;
        const double fc = g == 1 ? 0.0 : 2.0 * c / (g - 1) - 1.0;
        const double row = row0 + fr * span_row, col = col0 + fc * span_col;
        auto init = ocamLinearEstimate(boards, row, col, options.degree);
        if (init && (!best || init->rms_px < best->rms_px)) {
          best = std::move(init);
          best_row = row;
          best_col = col;
        }
      }
    }
    span_row /= g > 1 ? 0.5 * (g - 1) : 3.0;
    span_col /= g > 1 ? 0.5 * (g - 1) : 3.0;
  }
  if (!best && why)
    *why =
        "the linear initialisation found no usable model (degenerate boards: too few, all "
        "seen from the same direction, or corners in the wrong order)";
  return best;
}

}  // namespace ovo::calib
