// Levenberg-Marquardt with the inverse-depth landmarks eliminated by hand (landmark_schur.hpp).
#include "estimator/window/landmark_schur.hpp"

#include <ceres/manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "factors/robust_correction.hpp"

namespace ovo::estimator {
namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using ConstMatMap = Eigen::Map<const RowMatrix>;
using MatMap = Eigen::Map<RowMatrix>;
using ConstVecMap = Eigen::Map<const Eigen::VectorXd>;
using VecMap = Eigen::Map<Eigen::VectorXd>;

struct Block {
  double* x = nullptr;
  int ambient = 0, tangent = 0;
  LmBlockInfo info;
  int state = -1;     // offset in the packed ambient state (free blocks)
  int step = -1;      // offset in the packed tangent step (free blocks)
  int reduced = -1;   // offset in the reduced system (free blocks not eliminated)
  int landmark = -1;  // index of its landmark (eliminated blocks)
};

// One parameter block of one residual block.
struct Slot {
  int block = -1;     // block index
  int jacobian = -1;  // offset of its tangent Jacobian (m x tangent, row major); -1: constant
  int w = -1;         // offset of its part of the landmark's coupling column (a reduced block
                      // in a residual with a landmark), else -1
};

struct Residual {
  const ceres::CostFunction* cost = nullptr;
  const ceres::LossFunction* loss = nullptr;
  int m = 0;
  int r = 0;                 // offset of its residuals
  int first = 0, count = 0;  // its slots: [first, first + count) of Solver::slots_
  int landmark = -1;         // the slot of its eliminated block, -1: none
};

struct LandmarkRow {
  int block = -1;  // the eliminated block
  double h = 0.0, g = 0.0;
  int first = 0, last = 0;  // its couplings: [first, last) of Solver::couplings_
};

struct Coupling {
  int block = -1;  // a reduced block the landmark shares a residual with
  int w = 0;       // offset of sum J_b^T e over those residuals in Solver::w_
};

class Solver {
 public:
  Solver(const std::vector<LmResidual>& residuals,
         const std::unordered_map<const double*, LmBlockInfo>& info, const LmOptions& options);
  LmSummary run();

 private:
  bool evaluate(bool jacobians, double* cost, std::vector<double>* residuals);
  void normalEquations();
  void denseNormalEquations(const Residual& res);
  template <int M>
  void accumulate(const Residual& res);
  bool step(double radius, Eigen::VectorXd* delta);
  double modelCostChange(const Eigen::VectorXd& delta) const;
  void plus(const Eigen::VectorXd& delta);
  void restore();
  double damping(double h, double s, double radius) const {
    return std::clamp(s * s * h, options_.min_lm_diagonal, options_.max_lm_diagonal) /
           (radius * s * s);
  }

  LmOptions options_;
  ceres::EigenQuaternionManifold quaternion_;
  std::vector<Block> blocks_;
  std::vector<Residual> residuals_;
  std::vector<Slot> slots_;
  std::vector<double*> params_;  // per slot: the block's values (each residual's are contiguous)
  std::vector<double*> jac_ptrs_;
  std::vector<LandmarkRow> landmarks_;
  std::vector<Coupling> couplings_;
  int num_state_ = 0, num_step_ = 0, num_reduced_ = 0, num_r_ = 0, num_j_ = 0, num_w_ = 0;
  int max_ambient_jacobian_ = 0;

  std::vector<double> r_, J_, w_, scratch_;
  std::vector<double> candidate_r_;  // the candidate's residuals (r_ stays the state's)
  int max_m_ = 0;
  Eigen::VectorXd x_;        // the accepted state, packed
  Eigen::VectorXd scaling_;  // Jacobi scaling per step coordinate, from the start
  Eigen::VectorXd diag_;     // diag(J^T J) per step coordinate at the accepted state
  Eigen::MatrixXd H_;        // reduced blocks' J^T J
  Eigen::VectorXd g_;        // reduced blocks' J^T r
  Eigen::MatrixXd S_;
  Eigen::VectorXd rhs_;
};

Solver::Solver(const std::vector<LmResidual>& residuals,
               const std::unordered_map<const double*, LmBlockInfo>& info, const LmOptions& options)
    : options_(options) {
  std::unordered_map<const double*, int> index;
  index.reserve(info.size() + 64);
  residuals_.reserve(residuals.size());
  for (const LmResidual& in : residuals) {
    Residual res;
    res.cost = in.cost;
    res.loss = in.loss;
    res.m = in.cost->num_residuals();
    res.r = num_r_;
    max_m_ = std::max(max_m_, res.m);
    num_r_ += res.m;
    res.first = static_cast<int>(slots_.size());
    res.count = static_cast<int>(in.blocks->size());
    const auto& sizes = in.cost->parameter_block_sizes();
    int ambient_jacobian = 0;
    for (int i = 0; i < res.count; ++i) {
      double* x = (*in.blocks)[i];
      auto [it, added] = index.try_emplace(x, static_cast<int>(blocks_.size()));
      if (added) {
        Block b;
        b.x = x;
        b.ambient = sizes[i];
        if (auto f = info.find(x); f != info.end()) b.info = f->second;
        b.tangent = b.info.quaternion ? 3 : b.ambient;
        if (!b.info.constant) {
          b.state = num_state_;
          num_state_ += b.ambient;
          b.step = num_step_;
          num_step_ += b.tangent;
          if (b.info.eliminate && b.tangent == 1) {
            b.landmark = static_cast<int>(landmarks_.size());
            landmarks_.push_back({static_cast<int>(blocks_.size())});
          } else {
            b.reduced = num_reduced_;
            num_reduced_ += b.tangent;
          }
        }
        blocks_.push_back(b);
      }
      const Block& b = blocks_[it->second];
      Slot slot;
      slot.block = it->second;
      if (!b.info.constant) {
        slot.jacobian = num_j_;
        num_j_ += res.m * b.tangent;
      }
      if (b.landmark >= 0 && res.landmark < 0) res.landmark = res.first + i;
      slots_.push_back(slot);
      params_.push_back(x);
      ambient_jacobian += res.m * b.ambient;
    }
    max_ambient_jacobian_ = std::max(max_ambient_jacobian_, ambient_jacobian);
    residuals_.push_back(res);
  }
  // Each landmark's couplings: the reduced blocks it shares a residual with, and each slot's
  // place in them.
  std::vector<std::vector<int>> coupled(landmarks_.size());
  for (const Residual& res : residuals_) {
    if (res.landmark < 0) continue;
    auto& list = coupled[blocks_[slots_[res.landmark].block].landmark];
    for (int i = res.first; i < res.first + res.count; ++i) {
      const int b = slots_[i].block;
      if (blocks_[b].reduced >= 0 && std::find(list.begin(), list.end(), b) == list.end())
        list.push_back(b);
    }
  }
  for (std::size_t l = 0; l < landmarks_.size(); ++l) {
    landmarks_[l].first = static_cast<int>(couplings_.size());
    for (int b : coupled[l]) {
      couplings_.push_back({b, num_w_});
      num_w_ += blocks_[b].tangent;
    }
    landmarks_[l].last = static_cast<int>(couplings_.size());
  }
  for (const Residual& res : residuals_) {
    if (res.landmark < 0) continue;
    const LandmarkRow& lm = landmarks_[blocks_[slots_[res.landmark].block].landmark];
    for (int i = res.first; i < res.first + res.count; ++i)
      for (int c = lm.first; c < lm.last; ++c)
        if (couplings_[c].block == slots_[i].block) slots_[i].w = couplings_[c].w;
  }
  jac_ptrs_.resize(slots_.size());
  r_.resize(num_r_);
  candidate_r_.resize(num_r_);
  J_.resize(num_j_);
  w_.resize(num_w_);
  scratch_.resize(max_ambient_jacobian_);
  x_.resize(num_state_);
  for (const Block& b : blocks_)
    if (b.state >= 0) std::copy_n(b.x, b.ambient, x_.data() + b.state);
}

bool Solver::evaluate(bool jacobians, double* cost, std::vector<double>* residuals) {
  double total = 0.0;
  for (const Residual& res : residuals_) {
    double** jac = jac_ptrs_.data() + res.first;
    if (jacobians) {
      int offset = 0;
      for (int i = 0; i < res.count; ++i) {
        const Slot& slot = slots_[res.first + i];
        if (slot.jacobian < 0) {
          jac[i] = nullptr;
          continue;
        }
        jac[i] = scratch_.data() + offset;
        offset += res.m * blocks_[slot.block].ambient;
      }
    }
    double* r = residuals->data() + res.r;
    if (!res.cost->Evaluate(params_.data() + res.first, r, jacobians ? jac : nullptr)) return false;
    const double sq = ConstVecMap(r, res.m).squaredNorm();
    if (!std::isfinite(sq)) return false;
    // The robust loss as Ceres applies it: the cost rho(|r|^2) / 2, the Jacobian and residual
    // corrected (factors/robust_correction.hpp).
    double rho[3] = {sq, 1.0, 0.0};
    if (res.loss) res.loss->Evaluate(sq, rho);
    total += 0.5 * rho[0];
    if (!jacobians) continue;
    const ConstVecMap rv(r, res.m);
    const std::optional<factors::RobustCorrection> correction =
        res.loss ? std::optional<factors::RobustCorrection>(std::in_place, sq, rho) : std::nullopt;
    for (int i = 0; i < res.count; ++i) {
      const Slot& slot = slots_[res.first + i];
      if (slot.jacobian < 0) continue;
      const Block& b = blocks_[slot.block];
      const ConstMatMap Ja(jac[i], res.m, b.ambient);
      if (!Ja.allFinite()) return false;
      MatMap Jt(J_.data() + slot.jacobian, res.m, b.tangent);
      if (b.info.quaternion) {
        Eigen::Matrix<double, 4, 3, Eigen::RowMajor> P;
        quaternion_.PlusJacobian(b.x, P.data());
        Jt.noalias() = Ja * P;
      } else {
        Jt = Ja;
      }
      if (correction) correction->correctJacobian(Jt, rv);
    }
    if (correction) correction->correctResidual(VecMap(r, res.m));
  }
  *cost = total;
  return std::isfinite(total);
}

// A residual block this tall (the marginalisation prior: as many rows as the states it holds)
// goes through one dense product: its J^T J is most of the arithmetic of the normal equations.
constexpr int kDenseRows = 16;

void Solver::denseNormalEquations(const Residual& res) {
  int cols = 0;
  for (int i = res.first; i < res.first + res.count; ++i)
    if (slots_[i].jacobian >= 0) cols += blocks_[slots_[i].block].tangent;
  Eigen::MatrixXd J(res.m, cols);
  int c = 0;
  for (int i = res.first; i < res.first + res.count; ++i) {
    if (slots_[i].jacobian < 0) continue;
    const Block& b = blocks_[slots_[i].block];
    J.middleCols(c, b.tangent) = ConstMatMap(J_.data() + slots_[i].jacobian, res.m, b.tangent);
    c += b.tangent;
  }
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(cols, cols);
  JtJ.selfadjointView<Eigen::Upper>().rankUpdate(J.transpose());
  const Eigen::VectorXd Jtr = J.transpose() * ConstVecMap(r_.data() + res.r, res.m);
  const Eigen::VectorXd colnorm = J.colwise().squaredNorm().transpose();
  int ci = 0;
  for (int i = res.first; i < res.first + res.count; ++i) {
    if (slots_[i].jacobian < 0) continue;
    const Block& a = blocks_[slots_[i].block];
    diag_.segment(a.step, a.tangent) += colnorm.segment(ci, a.tangent);
    g_.segment(a.reduced, a.tangent) += Jtr.segment(ci, a.tangent);
    int cj = ci;
    for (int j = i; j < res.first + res.count; ++j) {
      if (slots_[j].jacobian < 0) continue;
      const Block& b = blocks_[slots_[j].block];
      for (int p = 0; p < a.tangent; ++p)
        for (int q = j == i ? p : 0; q < b.tangent; ++q) {
          const int row = a.reduced + p, col = b.reduced + q;
          const double v = JtJ(ci + p, cj + q);  // ci + p <= cj + q: JtJ's upper triangle
          if (row <= col)
            H_(row, col) += v;
          else
            H_(col, row) += v;
        }
      cj += b.tangent;
    }
    ci += a.tangent;
  }
}

namespace {

// The products of the normal equations for one pair of blocks of one residual block, over its M
// rows (M known at compile time for the common heights, so that the row loops unroll).
template <int M>
inline double columnDot(const double* A, int ta, int p, const double* B, int tb, int q, int m) {
  double v = 0.0;
  const int rows = M > 0 ? M : m;
  for (int k = 0; k < rows; ++k) v += A[k * ta + p] * B[k * tb + q];
  return v;
}

template <int M>
inline double columnDotVec(const double* A, int ta, int p, const double* r, int m) {
  double v = 0.0;
  const int rows = M > 0 ? M : m;
  for (int k = 0; k < rows; ++k) v += A[k * ta + p] * r[k];
  return v;
}

}  // namespace

template <int M>
void Solver::accumulate(const Residual& res) {
  const int n = num_reduced_;
  double* H = H_.data();  // column major; the upper triangle only (mirrored at the end)
  const double* r = r_.data() + res.r;
  const int m = res.m;
  const double* e = res.landmark >= 0 ? J_.data() + slots_[res.landmark].jacobian : nullptr;
  const int last = res.first + res.count;
  for (int i = res.first; i < last; ++i) {
    const Slot& sa = slots_[i];
    if (sa.jacobian < 0) continue;
    const Block& a = blocks_[sa.block];
    const double* Ja = J_.data() + sa.jacobian;
    const int ta = a.tangent;
    for (int p = 0; p < ta; ++p) diag_[a.step + p] += columnDot<M>(Ja, ta, p, Ja, ta, p, m);
    if (a.landmark >= 0) {
      LandmarkRow& lm = landmarks_[a.landmark];
      lm.h += columnDotVec<M>(Ja, 1, 0, Ja, m);
      lm.g += columnDotVec<M>(Ja, 1, 0, r, m);
      continue;
    }
    for (int p = 0; p < ta; ++p) g_[a.reduced + p] += columnDotVec<M>(Ja, ta, p, r, m);
    if (e != nullptr) {
      double* w = w_.data() + sa.w;
      for (int p = 0; p < ta; ++p) w[p] += columnDotVec<M>(Ja, ta, p, e, m);
    }
    for (int j = i; j < last; ++j) {
      const Slot& sb = slots_[j];
      if (sb.jacobian < 0) continue;
      const Block& b = blocks_[sb.block];
      if (b.reduced < 0) continue;
      const double* Jb = J_.data() + sb.jacobian;
      const int tb = b.tangent;
      const bool upper = a.reduced <= b.reduced;
      for (int p = 0; p < ta; ++p) {
        for (int q = j == i ? p : 0; q < tb; ++q) {  // a block with itself: q >= p only
          const double v = columnDot<M>(Ja, ta, p, Jb, tb, q, m);
          const int row = a.reduced + p, col = b.reduced + q;
          if (upper)
            H[row + static_cast<std::ptrdiff_t>(col) * n] += v;
          else
            H[col + static_cast<std::ptrdiff_t>(row) * n] += v;
        }
      }
    }
  }
}

// The loops are written out over the raw row-major Jacobians: the blocks are 1 to 5 columns wide
// and Eigen's dynamic-size products cost more in their set-up than in their arithmetic.
void Solver::normalEquations() {
  const int n = num_reduced_;
  H_.setZero(n, n);
  g_.setZero(n);
  diag_.setZero(num_step_);
  std::fill(w_.begin(), w_.end(), 0.0);
  for (LandmarkRow& lm : landmarks_) lm.h = lm.g = 0.0;
  for (const Residual& res : residuals_) {
    if (res.m >= kDenseRows && res.landmark < 0)
      denseNormalEquations(res);
    else if (res.m == 2)
      accumulate<2>(res);
    else if (res.m == 3)
      accumulate<3>(res);
    else if (res.m == 1)
      accumulate<1>(res);
    else
      accumulate<0>(res);
  }
  double* H = H_.data();
  for (int c = 0; c < n; ++c)
    for (int row = c + 1; row < n; ++row)
      H[row + static_cast<std::ptrdiff_t>(c) * n] = H[c + static_cast<std::ptrdiff_t>(row) * n];
}

bool Solver::step(double radius, Eigen::VectorXd* delta) {
  // Ceres' LM with Jacobi scaling, in unscaled coordinates: J^T J + diag(d / radius), d = diag
  // of the scaled J^T J clamped, taken back by the scaling.
  S_ = H_;
  rhs_ = -g_;
  for (const Block& b : blocks_) {
    if (b.reduced < 0) continue;
    for (int k = 0; k < b.tangent; ++k)
      S_(b.reduced + k, b.reduced + k) += damping(diag_[b.step + k], scaling_[b.step + k], radius);
  }
  std::vector<double> h(landmarks_.size());
  const int n = num_reduced_;
  double* S = S_.data();
  for (std::size_t l = 0; l < landmarks_.size(); ++l) {
    const LandmarkRow& lm = landmarks_[l];
    const Block& b = blocks_[lm.block];
    h[l] = lm.h + damping(diag_[b.step], scaling_[b.step], radius);
    if (!(h[l] > 0.0)) return false;
    const double inv = 1.0 / h[l];
    // S -= w w^T / h, rhs += w g / h over the blocks the landmark couples.
    for (int c = lm.first; c < lm.last; ++c) {
      const Block& bc = blocks_[couplings_[c].block];
      const double* wc = w_.data() + couplings_[c].w;
      for (int p = 0; p < bc.tangent; ++p) rhs_[bc.reduced + p] += inv * lm.g * wc[p];
      for (int d = lm.first; d < lm.last; ++d) {
        const Block& bd = blocks_[couplings_[d].block];
        const double* wd = w_.data() + couplings_[d].w;
        for (int q = 0; q < bd.tangent; ++q) {
          double* col = S + static_cast<std::ptrdiff_t>(bd.reduced + q) * n + bc.reduced;
          const double f = inv * wd[q];
          for (int p = 0; p < bc.tangent; ++p) col[p] -= f * wc[p];
        }
      }
    }
  }
  Eigen::VectorXd df;
  if (num_reduced_ > 0) {
    const Eigen::LLT<Eigen::MatrixXd> llt(S_);
    if (llt.info() != Eigen::Success) return false;
    df = llt.solve(rhs_);
  }
  delta->resize(num_step_);
  for (const Block& b : blocks_)
    if (b.reduced >= 0) delta->segment(b.step, b.tangent) = df.segment(b.reduced, b.tangent);
  for (std::size_t l = 0; l < landmarks_.size(); ++l) {
    const LandmarkRow& lm = landmarks_[l];
    double wdf = 0.0;
    for (int c = lm.first; c < lm.last; ++c) {
      const Block& bc = blocks_[couplings_[c].block];
      wdf += ConstVecMap(w_.data() + couplings_[c].w, bc.tangent)
                 .dot(df.segment(bc.reduced, bc.tangent));
    }
    (*delta)[blocks_[lm.block].step] = -(lm.g + wdf) / h[l];
  }
  return delta->allFinite();
}

double Solver::modelCostChange(const Eigen::VectorXd& delta) const {
  // -(J delta)^T (r + J delta / 2), with the (corrected) residuals and Jacobians of the state.
  double change = 0.0;
  std::vector<double> buffer(max_m_);
  for (const Residual& res : residuals_) {
    double* m = buffer.data();
    std::fill_n(m, res.m, 0.0);
    for (int i = res.first; i < res.first + res.count; ++i) {
      if (slots_[i].jacobian < 0) continue;
      const Block& b = blocks_[slots_[i].block];
      const double* J = J_.data() + slots_[i].jacobian;
      const double* d = delta.data() + b.step;
      for (int k = 0; k < res.m; ++k)
        for (int p = 0; p < b.tangent; ++p) m[k] += J[k * b.tangent + p] * d[p];
    }
    const double* r = r_.data() + res.r;
    for (int k = 0; k < res.m; ++k) change -= m[k] * (r[k] + 0.5 * m[k]);
  }
  return change;
}

void Solver::plus(const Eigen::VectorXd& delta) {
  for (const Block& b : blocks_) {
    if (b.state < 0) continue;
    const double* x = x_.data() + b.state;
    const double* d = delta.data() + b.step;
    if (b.info.quaternion) {
      quaternion_.Plus(x, d, b.x);
    } else {
      for (int k = 0; k < b.ambient; ++k) b.x[k] = x[k] + d[k];
    }
    for (int k = 0; k < b.ambient; ++k) b.x[k] = std::clamp(b.x[k], b.info.lower, b.info.upper);
  }
}

void Solver::restore() {
  for (const Block& b : blocks_)
    if (b.state >= 0) std::copy_n(x_.data() + b.state, b.ambient, b.x);
}

LmSummary Solver::run() {
  LmSummary summary;
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  // The start projected onto the bounds, as Ceres does.
  plus(Eigen::VectorXd::Zero(num_step_));
  for (const Block& b : blocks_)
    if (b.state >= 0) std::copy_n(b.x, b.ambient, x_.data() + b.state);
  double cost = 0.0;
  if (!evaluate(true, &cost, &r_)) {
    restore();
    summary.failed = true;
    summary.message = "the start could not be evaluated";
    return summary;
  }
  normalEquations();
  scaling_ = (1.0 / (1.0 + diag_.array().sqrt())).matrix();
  summary.initial_cost = summary.final_cost = cost;
  summary.iterations = 1;
  double radius = options_.initial_radius, decrease_factor = 2.0;
  int invalid = 0;
  Eigen::VectorXd delta;
  double x_norm = x_.norm();
  for (int it = 0; it < options_.max_iterations; ++it) {
    if (options_.max_time_s > 0.0 && elapsed() >= options_.max_time_s) {
      summary.message = "time limit";
      break;
    }
    if (radius <= options_.min_radius) {
      summary.message = "minimum trust region radius";
      break;
    }
    ++summary.iterations;
    double model_change = 0.0;
    const bool valid = step(radius, &delta) && (model_change = modelCostChange(delta)) > 0.0;
    if (!valid) {
      if (++invalid >= options_.max_consecutive_invalid_steps) {
        summary.failed = true;
        summary.message = "too many invalid steps";
        break;
      }
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    invalid = 0;
    plus(delta);
    double candidate = 0.0;
    if (!evaluate(false, &candidate, &candidate_r_)) candidate = std::numeric_limits<double>::max();
    double step_norm = 0.0;
    for (const Block& b : blocks_)
      if (b.state >= 0)
        step_norm += (ConstVecMap(b.x, b.ambient) - x_.segment(b.state, b.ambient)).squaredNorm();
    if (std::sqrt(step_norm) <=
        options_.parameter_tolerance * (x_norm + options_.parameter_tolerance)) {
      summary.message = "parameter tolerance";
      restore();
      break;
    }
    if (std::abs(cost - candidate) <= options_.function_tolerance * cost) {
      summary.message = "function tolerance";
      restore();
      break;
    }
    const double relative_decrease = (cost - candidate) / model_change;
    if (relative_decrease > options_.min_relative_decrease) {
      for (const Block& b : blocks_)
        if (b.state >= 0) std::copy_n(b.x, b.ambient, x_.data() + b.state);
      x_norm = x_.norm();
      const double cost_before = cost;
      cost = candidate;
      summary.final_cost = cost;
      ++summary.accepted;
      radius =
          std::min(options_.max_radius,
                   radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative_decrease - 1.0, 3)));
      decrease_factor = 2.0;
      if (cost_before - cost < options_.stop_decrease * cost_before) {
        summary.message = "cost decrease below stop_decrease";
        break;
      }
      if (it + 1 < options_.max_iterations) {
        if (!evaluate(true, &cost, &r_)) {
          summary.failed = true;
          summary.message = "the Jacobians could not be evaluated";
          break;
        }
        normalEquations();
      }
    } else {
      restore();
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
  }
  restore();  // the accepted state
  if (summary.message.empty()) summary.message = "iterations";
  return summary;
}

}  // namespace

LmSummary solveLandmarkSchur(const std::vector<LmResidual>& residuals,
                             const std::unordered_map<const double*, LmBlockInfo>& info,
                             const LmOptions& options) {
  if (residuals.empty()) return {};
  Solver solver(residuals, info, options);
  return solver.run();
}

}  // namespace ovo::estimator
