#include "factors/marginalization.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "factors/parameterization.hpp"
#include "factors/robust_correction.hpp"

namespace ovo::factors {

namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Ceres's tangent of EigenQuaternionManifold between q and q0 (both x, y, z, w): half the rotation
// vector of q q0^-1, taking the shortest rotation.
Vec3 quaternionMinus(const double* q, const double* q0) {
  Quat dq = quatFromBlock(q) * quatFromBlock(q0).conjugate();
  if (dq.w() < 0.0) dq.coeffs() = -dq.coeffs();
  const double n = dq.vec().norm();
  if (n < 1e-15) return dq.vec();
  return std::atan2(n, dq.w()) / n * dq.vec();
}

}  // namespace

void MarginalizationInfo::setQuaternionBlock(const double* block) {
  Block& b = blocks_[block];
  b.quaternion = true;
}

bool MarginalizationInfo::isQuaternion(const double* block) const {
  const auto it = blocks_.find(block);
  return it != blocks_.end() && it->second.quaternion;
}

bool MarginalizationInfo::addResidualBlock(const ceres::CostFunction* cost,
                                           const ceres::LossFunction* loss,
                                           const std::vector<double*>& blocks,
                                           const std::vector<int>& drop_indices) {
  const std::vector<int32_t>& sizes = cost->parameter_block_sizes();
  if (sizes.size() != blocks.size()) return false;
  for (int d : drop_indices)
    if (d < 0 || d >= static_cast<int>(blocks.size())) return false;
  Linearized lin;
  lin.blocks = blocks;
  lin.residual.resize(cost->num_residuals());
  std::vector<RowMajorMatrix> jac(blocks.size());
  std::vector<double*> jac_ptrs(blocks.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    jac[i].resize(cost->num_residuals(), sizes[i]);
    jac_ptrs[i] = jac[i].data();
  }
  if (!cost->Evaluate(blocks.data(), lin.residual.data(), jac_ptrs.data())) return false;
  if (!lin.residual.allFinite()) return false;

  // Robust loss: Triggs correction as Ceres applies it (ceres/corrector.cc semantics), so that the
  // prior sees the same J^T J and J^T r as the solver's last iteration.
  if (loss) {
    const double sq_norm = lin.residual.squaredNorm();
    double rho[3];
    loss->Evaluate(sq_norm, rho);
    const RobustCorrection correction(sq_norm, rho);
    for (auto& J : jac) correction.correctJacobian(J, lin.residual);
    correction.correctResidual(lin.residual);
  }

  for (std::size_t i = 0; i < blocks.size(); ++i) {
    auto [it, inserted] = blocks_.try_emplace(blocks[i]);
    Block& b = it->second;
    if (b.x0.empty()) {
      b.ambient = sizes[i];
      b.x0.assign(blocks[i], blocks[i] + sizes[i]);
      order_.push_back(blocks[i]);
    }
    lin.jacobians_ambient.emplace_back(jac[i]);
  }
  for (int d : drop_indices) blocks_[blocks[d]].dropped = true;
  residuals_.push_back(std::move(lin));
  return true;
}

std::vector<double*> MarginalizationInfo::droppedBlocks() const {
  std::vector<double*> out;
  for (double* p : order_)
    if (blocks_.at(p).dropped) out.push_back(p);
  return out;
}

std::vector<int> MarginalizationInfo::keptBlockSizes() const {
  std::vector<int> out;
  for (const double* p : kept_) out.push_back(blocks_.at(p).ambient);
  return out;
}

const std::vector<double>& MarginalizationInfo::linearizationPoint(const double* block) const {
  return blocks_.at(block).x0;
}

bool MarginalizationInfo::marginalize() {
  for (double* p : order_) {
    Block& b = blocks_.at(p);
    b.tangent = b.quaternion ? kQuatTangent : b.ambient;
  }
  // Dropped scalar blocks that share no residual with another dropped scalar block (inverse-depth
  // landmarks) are eliminated one by one: their part of H is diagonal, so each costs O(k^2) in
  // the k tangent dimensions it touches instead of a dense factorisation over all of them.
  std::unordered_map<const double*, int> scalar_index;
  for (double* p : order_) {
    const Block& b = blocks_.at(p);
    if (b.dropped && b.tangent == 1) scalar_index.emplace(p, -1);
  }
  for (const Linearized& lin : residuals_) {
    int scalars = 0;
    for (const double* p : lin.blocks) scalars += scalar_index.count(p) > 0;
    if (scalars < 2) continue;
    for (const double* p : lin.blocks) scalar_index.erase(p);
  }
  int num_scalars = 0;
  for (double* p : order_)
    if (auto it = scalar_index.find(p); it != scalar_index.end()) it->second = num_scalars++;

  // Tangent layout of the dense part: the other dropped blocks first (size m), then kept blocks.
  std::unordered_map<const double*, int> offset;
  int m = 0, n = 0;
  kept_.clear();
  for (double* p : order_) {
    const Block& b = blocks_.at(p);
    if (b.dropped && !scalar_index.count(p)) {
      offset[p] = m;
      m += b.tangent;
    }
  }
  n = m;
  for (double* p : order_) {
    const Block& b = blocks_.at(p);
    if (!b.dropped) {
      offset[p] = n;
      n += b.tangent;
      kept_.push_back(p);
    }
  }
  if (kept_.empty()) return false;

  // Per scalar block l: h_ll, g_l and its coupling H_xl to the dense part (sparse by offset).
  struct ScalarRow {
    double h = 0.0, g = 0.0;
    std::unordered_map<int, Eigen::VectorXd> coupling;  // dense offset -> H_xl segment
  };
  std::vector<ScalarRow> scalars(static_cast<std::size_t>(num_scalars));

  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  for (const Linearized& lin : residuals_) {
    std::vector<Eigen::MatrixXd> J_tan(lin.blocks.size());
    for (std::size_t i = 0; i < lin.blocks.size(); ++i) {
      const Block& b = blocks_.at(lin.blocks[i]);
      J_tan[i] =
          b.quaternion
              ? Eigen::MatrixXd(lin.jacobians_ambient[i] * quaternionPlusJacobian(b.x0.data()))
              : lin.jacobians_ambient[i];
    }
    for (std::size_t i = 0; i < lin.blocks.size(); ++i) {
      const auto si = scalar_index.find(lin.blocks[i]);
      if (si != scalar_index.end()) {
        ScalarRow& row = scalars[static_cast<std::size_t>(si->second)];
        row.h += J_tan[i].squaredNorm();
        row.g += J_tan[i].col(0).dot(lin.residual);
        for (std::size_t j = 0; j < lin.blocks.size(); ++j) {
          if (j == i) continue;
          const int oj = offset.at(lin.blocks[j]);
          Eigen::VectorXd c = J_tan[j].transpose() * J_tan[i].col(0);
          auto [it, inserted] = row.coupling.try_emplace(oj, c);
          if (!inserted) it->second += c;
        }
        continue;
      }
      const int oi = offset.at(lin.blocks[i]);
      const int ti = static_cast<int>(J_tan[i].cols());
      g.segment(oi, ti) += J_tan[i].transpose() * lin.residual;
      for (std::size_t j = 0; j < lin.blocks.size(); ++j) {
        if (scalar_index.count(lin.blocks[j])) continue;
        const int oj = offset.at(lin.blocks[j]);
        H.block(oi, oj, ti, J_tan[j].cols()) += J_tan[i].transpose() * J_tan[j];
      }
    }
  }

  // Scalar blocks out: H -= H_xl H_lx / h_ll, g -= H_xl g_l / h_ll (a zero h_ll, i.e. an
  // unobserved block, contributes nothing, as the pseudo-inverse below would).
  for (const ScalarRow& row : scalars) {
    if (!(row.h > options_.eigenvalue_threshold_abs)) continue;
    const double inv_h = 1.0 / row.h;
    for (const auto& [oi, ci] : row.coupling) {
      g.segment(oi, ci.size()) -= ci * (row.g * inv_h);
      for (const auto& [oj, cj] : row.coupling)
        H.block(oi, oj, ci.size(), cj.size()) -= ci * cj.transpose() * inv_h;
    }
  }

  const auto thresholdOf = [this](const Eigen::VectorXd& lambda) {
    const double top = lambda.size() ? lambda.maxCoeff() : 0.0;
    return std::max(options_.eigenvalue_threshold_abs, options_.eigenvalue_threshold_rel * top);
  };

  // Schur complement: H_p = H_rr - H_rm H_mm^+ H_mr, b_p = b_r - H_rm H_mm^+ b_m.
  const int r = n - m;
  if (m > 0) {
    const Eigen::MatrixXd H_mm = 0.5 * (H.topLeftCorner(m, m) + H.topLeftCorner(m, m).transpose());
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_mm(H_mm);
    const double thr = thresholdOf(eig_mm.eigenvalues());
    const Eigen::VectorXd inv_lambda =
        (eig_mm.eigenvalues().array() > thr).select(eig_mm.eigenvalues().cwiseInverse(), 0.0);
    const Eigen::MatrixXd H_mm_inv =
        eig_mm.eigenvectors() * inv_lambda.asDiagonal() * eig_mm.eigenvectors().transpose();
    const Eigen::MatrixXd H_rm_Hinv = H.bottomLeftCorner(r, m) * H_mm_inv;
    H_prior_ = H.bottomRightCorner(r, r) - H_rm_Hinv * H.topRightCorner(m, r);
    b_prior_ = g.tail(r) - H_rm_Hinv * g.head(m);
  } else {
    H_prior_ = H;
    b_prior_ = g;
  }
  H_prior_ = 0.5 * (H_prior_ + H_prior_.transpose()).eval();

  // H_p = V L V^T -> S = L^1/2 V^T, e0 = L^-1/2 V^T b_p over the eigenvalues above the threshold.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H_prior_);
  const double thr = thresholdOf(eig.eigenvalues());
  std::vector<int> keep;
  for (int i = 0; i < r; ++i)
    if (eig.eigenvalues()[i] > thr) keep.push_back(i);
  if (keep.empty()) return false;
  S_.resize(static_cast<int>(keep.size()), r);
  e0_.resize(static_cast<int>(keep.size()));
  for (std::size_t k = 0; k < keep.size(); ++k) {
    const double lambda = eig.eigenvalues()[keep[k]];
    const Eigen::VectorXd v = eig.eigenvectors().col(keep[k]);
    S_.row(static_cast<int>(k)) = std::sqrt(lambda) * v.transpose();
    e0_[static_cast<int>(k)] = v.dot(b_prior_) / std::sqrt(lambda);
  }
  residuals_.clear();
  return true;
}

MarginalizationInfo::BlockMap MarginalizationInfo::scaling(const double* block,
                                                           const Eigen::Vector3d& centre,
                                                           double s) {
  return {block, s * Eigen::Matrix3d::Identity(), (1.0 - s) * centre};
}

std::shared_ptr<const MarginalizationInfo> MarginalizationInfo::mapped(
    const std::vector<BlockMap>& maps) const {
  auto out = std::make_shared<MarginalizationInfo>(*this);
  // The prior r = S dx + e0 in dx' = M dx: the block's columns of S (and of H with its rows, and
  // b) times M^-1.
  int offset = 0;
  for (double* kept : kept_) {
    Block& b = out->blocks_.at(kept);
    const auto map =
        std::find_if(maps.begin(), maps.end(), [&](const BlockMap& m) { return m.block == kept; });
    if (map != maps.end() && !b.quaternion && b.ambient == 3) {
      const Eigen::Map<Eigen::Vector3d> x0(b.x0.data());
      const Eigen::Vector3d moved = map->M * x0 + map->k;
      std::copy_n(moved.data(), 3, b.x0.data());
      const Eigen::Matrix3d Minv = map->M.inverse();
      out->S_.middleCols(offset, 3) = (out->S_.middleCols(offset, 3) * Minv).eval();
      out->H_prior_.middleCols(offset, 3) = (out->H_prior_.middleCols(offset, 3) * Minv).eval();
      out->H_prior_.middleRows(offset, 3) =
          (Minv.transpose() * out->H_prior_.middleRows(offset, 3)).eval();
      out->b_prior_.segment(offset, 3) =
          (Minv.transpose() * out->b_prior_.segment(offset, 3)).eval();
    }
    offset += b.tangent;
  }
  return out;
}

MarginalizationFactor::MarginalizationFactor(std::shared_ptr<const MarginalizationInfo> info)
    : info_(std::move(info)) {
  set_num_residuals(static_cast<int>(info_->S_.rows()));
  for (int size : info_->keptBlockSizes()) mutable_parameter_block_sizes()->push_back(size);
}

bool MarginalizationFactor::Evaluate(double const* const* parameters, double* residuals,
                                     double** jacobians) const {
  const Eigen::MatrixXd& S = info_->S_;
  const int rows = static_cast<int>(S.rows());
  Eigen::VectorXd dx(S.cols());
  int offset = 0;
  for (std::size_t i = 0; i < info_->kept_.size(); ++i) {
    const auto& b = info_->blocks_.at(info_->kept_[i]);
    if (b.quaternion) {
      dx.segment<3>(offset) = quaternionMinus(parameters[i], b.x0.data());
    } else {
      for (int k = 0; k < b.ambient; ++k) dx[offset + k] = parameters[i][k] - b.x0[k];
    }
    offset += b.tangent;
  }
  Eigen::Map<Eigen::VectorXd> residual(residuals, rows);
  residual = S * dx + info_->e0_;
  if (!jacobians) return true;

  offset = 0;
  for (std::size_t i = 0; i < info_->kept_.size(); ++i) {
    const auto& b = info_->blocks_.at(info_->kept_[i]);
    if (jacobians[i]) {
      Eigen::Map<RowMajorMatrix> J(jacobians[i], rows, b.ambient);
      if (b.quaternion) {
        // Minus(Plus(q, d), q0) = phi/2 + Jl^-1(phi) d with phi = 2 dx; Jl^-1 = Jr^-T.
        const Vec3 phi = 2.0 * dx.segment<3>(offset);
        J = S.middleCols<3>(offset) * so3::rightJacobianInverse(phi).transpose() *
            quaternionPlusJacobian(parameters[i]).transpose();
      } else {
        J = S.middleCols(offset, b.ambient);
      }
    }
    offset += b.tangent;
  }
  return true;
}

}  // namespace ovo::factors
