#include "frontend/essential.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "common/so3.hpp"
#include "frontend/triangulation.hpp"
#include "gpu/hypotheses.hpp"

namespace ovo::frontend {
namespace {

using Vec9 = Eigen::Matrix<double, 9, 1>;

Mat3 fromRowMajor(const Vec9& e) {
  Mat3 E;
  E << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  return E;
}

}  // namespace

Mat3 essentialFromMotion(const Mat3& R_cur_prev, const Vec3& t_cur_prev) {
  return so3::hat(t_cur_prev) * R_cur_prev;
}

std::optional<Mat3> eightPointMinimal(const std::array<Vec3, 8>& b_prev,
                                      const std::array<Vec3, 8>& b_cur) {
  // The RANSAC hypotheses' own solver, the sample copied into every lane.
  constexpr int L = gpu::kEightPointLanes;
  double prev[8][3][L], cur[8][3][L], E[9][L];
  bool valid[L];
  for (int i = 0; i < 8; ++i)
    for (int r = 0; r < 3; ++r)
      for (int l = 0; l < L; ++l) {
        prev[i][r][l] = b_prev[i](r);
        cur[i][r][l] = b_cur[i](r);
      }
  gpu::eightPointLanes(prev, cur, E, valid);
  if (!valid[0]) return std::nullopt;
  Mat3 out;
  for (int j = 0; j < 9; ++j) out(j / 3, j % 3) = E[j][0];
  return out;
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
                                                 int* num_positive,
                                                 const ParallelFor& parallel_for) {
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
  std::array<int, 4> counts{};
  auto vote = [&](int k_begin, int k_end) {
    for (int k = k_begin; k < k_end; ++k)
      for (std::size_t i : voters) {
        const auto p = triangulateMidpoint(candidates[k].R_cur_prev, candidates[k].t_cur_prev,
                                           b_prev[i], b_cur[i], 1e-6);
        if (p && p->depth_prev > 0.0 && p->depth_cur > 0.0) ++counts[k];
      }
  };
  if (parallel_for)
    parallel_for(4, vote);
  else
    vote(0, 4);
  int best_count = 0, best = -1;
  for (int k = 0; k < 4; ++k)
    if (counts[k] > best_count) {
      best_count = counts[k];
      best = k;
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

namespace {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;

// Matches per reduction chunk of the refinement: partial sums are formed per chunk and added in
// chunk order, so the result does not depend on how many threads ran the chunks.
constexpr int kRefineChunk = 128;

// The robust cost sum rho(min(e_i, 1)) at a motion, and the Gauss-Newton system H, g of the
// residuals r_i = num_i / sqrt(den_i) in the 5-parameter tangent space (R Exp(w), t + B dt).
struct RefineSystem {
  double cost = 0.0;
  Mat5 H = Mat5::Zero();
  Vec5 g = Vec5::Zero();
};

RefineSystem refineSystem(const RelativeMotion& m, const Vec3& B1, const Vec3& B2,
                          const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                          const std::vector<std::uint8_t>& flags, double c2,
                          const ParallelFor& parallel_for) {
  const int n = static_cast<int>(std::min(b_prev.size(), b_cur.size()));
  const int chunks = (n + kRefineChunk - 1) / kRefineChunk;
  std::vector<RefineSystem> partial(chunks);
  const Mat3& R = m.R_cur_prev;
  const Vec3& t = m.t_cur_prev;
  Eigen::Matrix<double, 3, 2> B;
  B << B1, B2;
  auto run = [&](int chunk_begin, int chunk_end) {
    for (int ch = chunk_begin; ch < chunk_end; ++ch) {
      RefineSystem& sys = partial[ch];
      const int i1 = std::min(n, (ch + 1) * kRefineChunk);
      for (int i = ch * kRefineChunk; i < i1; ++i) {
        if (!flags.empty() && !flags[i]) continue;
        // a = E b_p = t x R b_p, c = E^T b_c = R^T (b_c x t), num = b_c . a,
        // den = |a|^2 + |c|^2 - 2 num^2 (the sphere error's denominator for unit bearings). For
        // R <- R Exp(w), t <- t + B dt:
        //   d num/dw = (b_p x R^T (b_c x t))^T,     d num/dt = (R b_p x b_c)^T B,
        //   a^T da/dw = (R^T (t x a) x b_p)^T,      a^T da/dt = -(a x R b_p)^T B,
        //   c^T dc/dw = 0 (dc/dw = [c]x),           c^T dc/dt = (R c x b_c)^T B,
        //   dr = d num / sqrt(den) - num d den / (2 den^1.5), d den = 2 a^T da + 2 c^T dc -
        //   4 num d num.
        const Vec3 Rb = R * b_prev[i];
        const Vec3 a = t.cross(Rb);
        const Vec3 c = R.transpose() * b_cur[i].cross(t);
        const double num = b_cur[i].dot(a);
        const double den = a.squaredNorm() + c.squaredNorm() - 2.0 * num * num;
        if (!(den > 1e-12)) {
          sys.cost += c2 > 0.0 ? c2 * std::log1p(1.0 / c2) : 1.0;
          continue;
        }
        const double e = std::min(num * num / den, 1.0);
        sys.cost += c2 > 0.0 ? c2 * std::log1p(e / c2) : e;
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
        sys.H.selfadjointView<Eigen::Upper>().rankUpdate(J, robust);
        sys.g += robust * r * J;
      }
    }
  };
  if (parallel_for)
    parallel_for(chunks, run);
  else
    run(0, chunks);
  RefineSystem total;
  for (const RefineSystem& p : partial) {
    total.cost += p.cost;
    total.H += p.H;
    total.g += p.g;
  }
  total.H.triangularView<Eigen::StrictlyLower>() = total.H.transpose();
  return total;
}

// A tangent basis (B1, B2) at the unit vector t.
std::pair<Vec3, Vec3> tangentBasis(const Vec3& t) {
  const Vec3 helper = std::abs(t.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 B1 = t.cross(helper).normalized();
  return {B1, t.cross(B1)};
}

}  // namespace

RelativeMotion refineOnSphere(const RelativeMotion& init, const std::vector<Vec3>& b_prev,
                              const std::vector<Vec3>& b_cur,
                              const std::vector<std::uint8_t>& flags, int max_iterations,
                              double cauchy_scale_rad, const ParallelFor& parallel_for) {
  const double c2 = cauchy_scale_rad * cauchy_scale_rad;
  RelativeMotion cur = init;
  if (cur.t_cur_prev.norm() == 0.0 || !cur.R_cur_prev.allFinite()) return init;
  cur.t_cur_prev.normalize();
  auto [B1, B2] = tangentBasis(cur.t_cur_prev);
  RefineSystem sys = refineSystem(cur, B1, B2, b_prev, b_cur, flags, c2, parallel_for);
  double lambda = 1e-4;
  for (int it = 0; it < max_iterations; ++it) {
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Mat5 A = sys.H;
      A.diagonal() += lambda * sys.H.diagonal().cwiseMax(1e-12);
      const Vec5 step = A.ldlt().solve(-sys.g);
      if (!step.allFinite()) break;
      RelativeMotion next;
      next.R_cur_prev = so3::orthonormalize(cur.R_cur_prev * so3::exp(step.head<3>()));
      next.t_cur_prev = (cur.t_cur_prev + step(3) * B1 + step(4) * B2).normalized();
      // The cost at `next` comes with its normal equations (used when the step is taken).
      const auto [nB1, nB2] = tangentBasis(next.t_cur_prev);
      RefineSystem next_sys = refineSystem(next, nB1, nB2, b_prev, b_cur, flags, c2, parallel_for);
      if (next_sys.cost < sys.cost) {
        const bool converged = step.norm() < 1e-9 || sys.cost - next_sys.cost < 1e-7 * sys.cost;
        cur = next;
        B1 = nB1;
        B2 = nB2;
        sys = std::move(next_sys);
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
