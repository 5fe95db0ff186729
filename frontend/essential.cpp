#include "frontend/essential.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "common/so3.hpp"
#include "frontend/triangulation.hpp"

namespace ovo::frontend {
namespace {

using Vec9 = Eigen::Matrix<double, 9, 1>;

Mat3 fromRowMajor(const Vec9& e) {
  Mat3 E;
  E << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  return E;
}

// Fast projection for hypotheses: eigenvectors v1, v2 of E^T E (closed form) span the row space;
// E_hat = sum_i (E v_i / |E v_i|) v_i^T has singular values (1, 1, 0).
std::optional<Mat3> projectToEssentialFast(const Mat3& E) {
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  eig.computeDirect(E.transpose() * E);
  const Vec3 v1 = eig.eigenvectors().col(1), v2 = eig.eigenvectors().col(2);
  const Vec3 u1 = E * v1, u2 = E * v2;
  const double n1 = u1.norm(), n2 = u2.norm();
  if (!(n2 > 0.0) || !(n1 > 1e-9 * n2)) return std::nullopt;
  Mat3 out = (u1 / n1) * v1.transpose() + (u2 / n2) * v2.transpose();
  if (!out.allFinite()) return std::nullopt;
  return out;
}

}  // namespace

Mat3 essentialFromMotion(const Mat3& R_cur_prev, const Vec3& t_cur_prev) {
  return so3::hat(t_cur_prev) * R_cur_prev;
}

std::optional<Mat3> eightPointMinimal(const std::array<Vec3, 8>& b_prev,
                                      const std::array<Vec3, 8>& b_cur) {
  // Rows A_i = kron(b_cur, b_prev): A_i vec_rowmajor(E) = b_cur^T E b_prev.
  double A[8][9];
  int col_of[9];
  double scale = 0.0;
  for (int i = 0; i < 8; ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        A[i][3 * r + c] = b_cur[i](r) * b_prev[i](c);
        scale = std::max(scale, std::abs(A[i][3 * r + c]));
      }
  if (!(scale > 0.0) || !std::isfinite(scale)) return std::nullopt;
  for (int j = 0; j < 9; ++j) col_of[j] = j;

  // Gaussian elimination with row pivoting, switching to full pivoting for a column whose best
  // pivot is small (rank-deficient or badly conditioned samples); stops at the numerical rank.
  const double tol = 1e-11 * scale;
  int rank = 0;
  for (int k = 0; k < 8; ++k) {
    int pi = k, pj = k;
    double best = 0.0;
    for (int i = k; i < 8; ++i)
      if (std::abs(A[i][k]) > best) {
        best = std::abs(A[i][k]);
        pi = i;
      }
    if (best < 1e-3 * scale)
      for (int i = k; i < 8; ++i)
        for (int j = k; j < 9; ++j)
          if (std::abs(A[i][j]) > best) {
            best = std::abs(A[i][j]);
            pi = i;
            pj = j;
          }
    if (best <= tol) break;
    if (pi != k)
      for (int j = 0; j < 9; ++j) std::swap(A[k][j], A[pi][j]);
    if (pj != k) {
      for (int i = 0; i < 8; ++i) std::swap(A[i][k], A[i][pj]);
      std::swap(col_of[k], col_of[pj]);
    }
    const double inv = 1.0 / A[k][k];
    for (int i = k + 1; i < 8; ++i) {
      const double f = A[i][k] * inv;
      if (f == 0.0) continue;
      for (int j = k; j < 9; ++j) A[i][j] -= f * A[k][j];
    }
    rank = k + 1;
  }
  if (rank < 5) return std::nullopt;
  // One null vector: the last free variable set to 1, the other free ones to 0.
  double x[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  x[8] = 1.0;
  for (int k = rank - 1; k >= 0; --k) {
    double s = 0.0;
    for (int j = k + 1; j < 9; ++j) s += A[k][j] * x[j];
    x[k] = -s / A[k][k];
  }
  Vec9 e;
  for (int j = 0; j < 9; ++j) e(col_of[j]) = x[j];
  const double norm = e.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return std::nullopt;
  return projectToEssentialFast(fromRowMajor(e / norm));
}

std::optional<Mat3> eightPoint(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                               const std::vector<std::uint8_t>& flags) {
  const std::size_t n = std::min(b_prev.size(), b_cur.size());
  int m = 0;
  for (std::size_t i = 0; i < n; ++i) m += (flags.empty() || flags[i]) ? 1 : 0;
  if (m < 8) return std::nullopt;
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(m, 9);
  int row = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!flags.empty() && !flags[i]) continue;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) A(row, 3 * r + c) = b_cur[i](r) * b_prev[i](c);
    ++row;
  }
  if (!A.allFinite()) return std::nullopt;
  Vec9 e;
  if (m == 8) {
    Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 9>> svd(A, Eigen::ComputeFullV);
    e = svd.matrixV().col(8);
  } else {
    // QR first: the 9x9 R has A's singular values and right singular vectors, and its SVD is cheap.
    Eigen::HouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, 9>> qr(A);
    const Eigen::Matrix<double, 9, 9> R = qr.matrixQR().topRows<9>().triangularView<Eigen::Upper>();
    Eigen::JacobiSVD<Eigen::Matrix<double, 9, 9>> svd(R, Eigen::ComputeFullV);
    e = svd.matrixV().col(8);
  }
  return projectToEssential(fromRowMajor(e));
}

std::optional<Mat3> projectToEssential(const Mat3& E) {
  if (!E.allFinite()) return std::nullopt;
  Eigen::JacobiSVD<Mat3> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 s = svd.singularValues();
  if (!(s(0) > 0.0) || !(s(1) > 1e-12 * s(0))) return std::nullopt;
  return Mat3(svd.matrixU() * Vec3(1.0, 1.0, 0.0).asDiagonal() * svd.matrixV().transpose());
}

double sphereError(const Mat3& E, const Vec3& b_prev, const Vec3& b_cur) {
  const Vec3 a = E * b_prev;
  const Vec3 c = E.transpose() * b_cur;
  const double num = b_cur.dot(a);
  const double den =
      (a - b_cur * b_cur.dot(a)).squaredNorm() + (c - b_prev * b_prev.dot(c)).squaredNorm();
  if (!(den > 0.0)) return std::numeric_limits<double>::infinity();
  const double err = num * num / den;
  return std::isfinite(err) ? err : std::numeric_limits<double>::infinity();
}

std::array<RelativeMotion, 4> decomposeEssential(const Mat3& E) {
  Eigen::JacobiSVD<Mat3> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU(), V = svd.matrixV();
  if (U.determinant() < 0) U = -U;
  if (V.determinant() < 0) V = -V;
  Mat3 W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Mat3 R1 = U * W * V.transpose();
  const Mat3 R2 = U * W.transpose() * V.transpose();
  const Vec3 t = U.col(2).normalized();
  return {RelativeMotion{R1, t}, RelativeMotion{R1, -t}, RelativeMotion{R2, t},
          RelativeMotion{R2, -t}};
}

std::optional<RelativeMotion> selectByCheirality(const Mat3& E, const std::vector<Vec3>& b_prev,
                                                 const std::vector<Vec3>& b_cur,
                                                 const std::vector<std::uint8_t>& flags,
                                                 int* num_positive) {
  if (!E.allFinite()) return std::nullopt;
  const auto candidates = decomposeEssential(E);
  const std::size_t n = std::min(b_prev.size(), b_cur.size());
  // At most kMaxVotes matches, spread evenly over the flagged ones, vote.
  constexpr std::size_t kMaxVotes = 300;
  std::vector<std::size_t> voters;
  for (std::size_t i = 0; i < n; ++i)
    if (flags.empty() || flags[i]) voters.push_back(i);
  if (voters.size() > kMaxVotes) {
    std::vector<std::size_t> kept(kMaxVotes);
    for (std::size_t j = 0; j < kMaxVotes; ++j) kept[j] = voters[j * voters.size() / kMaxVotes];
    voters = std::move(kept);
  }
  int best_count = 0, best = -1;
  for (int k = 0; k < 4; ++k) {
    int count = 0;
    for (std::size_t i : voters) {
      const auto p = triangulateMidpoint(candidates[k].R_cur_prev, candidates[k].t_cur_prev,
                                         b_prev[i], b_cur[i], 1e-6);
      if (p && p->depth_prev > 0.0 && p->depth_cur > 0.0) ++count;
    }
    if (count > best_count) {
      best_count = count;
      best = k;
    }
  }
  if (num_positive) *num_positive = best_count;
  if (best < 0) return std::nullopt;
  return candidates[best];
}

std::optional<Mat3> rotationOnly(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                                 const std::vector<std::uint8_t>& flags) {
  // max sum b_cur^T R b_prev = trace(R M), M = sum b_prev b_cur^T = U S V^T -> R = V D U^T.
  Mat3 M = Mat3::Zero();
  int m = 0;
  const std::size_t n = std::min(b_prev.size(), b_cur.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (!flags.empty() && !flags[i]) continue;
    M += b_prev[i] * b_cur[i].transpose();
    ++m;
  }
  if (m < 2 || !M.allFinite()) return std::nullopt;
  Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3 U = svd.matrixU(), V = svd.matrixV();
  const double d = (V * U.transpose()).determinant() < 0 ? -1.0 : 1.0;
  return Mat3(V * Vec3(1.0, 1.0, d).asDiagonal() * U.transpose());
}

RelativeMotion refineOnSphere(const RelativeMotion& init, const std::vector<Vec3>& b_prev,
                              const std::vector<Vec3>& b_cur,
                              const std::vector<std::uint8_t>& flags, int max_iterations,
                              double cauchy_scale_rad) {
  using Vec5 = Eigen::Matrix<double, 5, 1>;
  using Mat5 = Eigen::Matrix<double, 5, 5>;
  const std::size_t n = std::min(b_prev.size(), b_cur.size());
  const double c2 = cauchy_scale_rad * cauchy_scale_rad;
  auto rho = [&](double e) { return c2 > 0.0 ? c2 * std::log1p(e / c2) : e; };
  auto cost = [&](const RelativeMotion& m) {
    const Mat3 E = essentialFromMotion(m.R_cur_prev, m.t_cur_prev);
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      if (flags.empty() || flags[i]) sum += rho(std::min(sphereError(E, b_prev[i], b_cur[i]), 1.0));
    return sum;
  };
  RelativeMotion cur = init;
  if (cur.t_cur_prev.norm() == 0.0 || !cur.R_cur_prev.allFinite()) return init;
  cur.t_cur_prev.normalize();
  double cur_cost = cost(cur);
  double lambda = 1e-4;
  for (int it = 0; it < max_iterations; ++it) {
    const Mat3& R = cur.R_cur_prev;
    const Vec3& t = cur.t_cur_prev;
    const Vec3 helper = std::abs(t.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 B1 = t.cross(helper).normalized();
    const Vec3 B2 = t.cross(B1);
    // Residual r = num / sqrt(den) with unit bearings, a = E b_p = t x R b_p, c = E^T b_c =
    // R^T (b_c x t), num = b_c . a, den = |a|^2 + |c|^2 - 2 num^2. For R <- R Exp(w), t <- t + B
    // dt:
    //   d num/dw = (b_p x R^T (b_c x t))^T,     d num/dt = (R b_p x b_c)^T B,
    //   a^T da/dw = (R^T (t x a) x b_p)^T,      a^T da/dt = -(a x R b_p)^T B,
    //   c^T dc/dw = 0 (dc/dw = [c]x),           c^T dc/dt = (R c x b_c)^T B,
    //   dr = d num / sqrt(den) - num d den / (2 den^1.5), d den = 2 a^T da + 2 c^T dc - 4 num d
    //   num.
    Mat5 H = Mat5::Zero();
    Vec5 g = Vec5::Zero();
    Eigen::Matrix<double, 3, 2> B;
    B << B1, B2;
    for (std::size_t i = 0; i < n; ++i) {
      if (!flags.empty() && !flags[i]) continue;
      const Vec3 Rb = R * b_prev[i];
      const Vec3 a = t.cross(Rb);
      const Vec3 bc_x_t = b_cur[i].cross(t);
      const Vec3 c = R.transpose() * bc_x_t;
      const double num = b_cur[i].dot(a);
      const double den = a.squaredNorm() + c.squaredNorm() - 2.0 * num * num;
      if (!(den > 1e-12)) continue;
      Vec5 dnum, dden;
      dnum.head<3>() = b_prev[i].cross(c);
      dnum.tail<2>() = B.transpose() * Rb.cross(b_cur[i]);
      dden.head<3>() = 2.0 * (R.transpose() * t.cross(a)).cross(b_prev[i]);
      dden.tail<2>() = 2.0 * B.transpose() * ((R * c).cross(b_cur[i]) - a.cross(Rb));
      dden -= 4.0 * num * dnum;
      const double sqrt_den = std::sqrt(den);
      const double r = num / sqrt_den;
      const Vec5 J = dnum / sqrt_den - (num / (2.0 * den * sqrt_den)) * dden;
      // Iteratively reweighted: the Cauchy weight 1 / (1 + e / c^2) scales J^T J and J^T r.
      const double robust = c2 > 0.0 ? 1.0 / (1.0 + r * r / c2) : 1.0;
      H += robust * J * J.transpose();
      g += robust * J * r;
    }
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Mat5 A = H;
      A.diagonal() += lambda * H.diagonal().cwiseMax(1e-12);
      const Vec5 step = A.ldlt().solve(-g);
      if (!step.allFinite()) break;
      RelativeMotion next;
      next.R_cur_prev = so3::orthonormalize(R * so3::exp(step.head<3>()));
      next.t_cur_prev = (t + step(3) * B1 + step(4) * B2).normalized();
      const double next_cost = cost(next);
      if (next_cost < cur_cost) {
        const bool converged = step.norm() < 1e-9 || cur_cost - next_cost < 1e-7 * cur_cost;
        cur = next;
        cur_cost = next_cost;
        lambda = std::max(lambda * 0.1, 1e-10);
        improved = true;
        if (converged) return cur;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return cur;
}

}  // namespace ovo::frontend
