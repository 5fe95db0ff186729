// Marginalisation prior (as in VINS-Mono and OKVIS): the residual blocks touching the states that
// leave the window are linearised once, their states are Schur-complemented out, and what remains
// is a fixed linear prior on the states they shared with the window.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <Eigen/Core>
#include <memory>
#include <unordered_map>
#include <vector>

namespace ovo::factors {

/// Collects linearised residual blocks, marginalises the dropped parameter blocks and holds the
/// resulting prior H_p = S^T S, b_p (gradient) on the kept blocks at their linearisation point x0.
/// Usage: setQuaternionBlock() for every q_W_B block involved (others are Euclidean),
/// addResidualBlock() for every residual touching a dropped block (including the previous
/// MarginalizationFactor), marginalize(), then add a MarginalizationFactor over keptBlocks().
class MarginalizationInfo {
 public:
  struct Options {
    double eigenvalue_threshold_abs = 1e-10;  // eigenvalues below are treated as zero
    double eigenvalue_threshold_rel = 1e-12;  // ... or below this fraction of the largest one
  };
  MarginalizationInfo() = default;
  explicit MarginalizationInfo(const Options& options) : options_(options) {}

  /// Declares `block` an EigenQuaternionManifold block (4 ambient / 3 tangent values).
  void setQuaternionBlock(const double* block);

  /// Evaluates `cost` (with `loss`, may be null) at the blocks' current values, which become the
  /// linearisation point; drop_indices says which of `blocks` are marginalised. Nothing is owned
  /// or kept: cost and loss may be destroyed afterwards. Returns false if the evaluation fails.
  bool addResidualBlock(const ceres::CostFunction* cost, const ceres::LossFunction* loss,
                        const std::vector<double*>& blocks, const std::vector<int>& drop_indices);

  /// Forms J^T J and J^T r in the tangent spaces, Schur-complements out the dropped blocks and
  /// factorises the prior. False when nothing is kept or the prior has rank 0.
  bool marginalize();

  /// Blocks of the prior, in the order MarginalizationFactor expects them.
  const std::vector<double*>& keptBlocks() const { return kept_; }
  std::vector<double*> droppedBlocks() const;
  /// Ambient size of each kept block.
  std::vector<int> keptBlockSizes() const;
  bool isQuaternion(const double* block) const;

  /// The prior in the kept blocks' tangent spaces (Ceres's tangent of EigenQuaternionManifold).
  const Eigen::MatrixXd& priorHessian() const { return H_prior_; }
  const Eigen::VectorXd& priorGradient() const { return b_prior_; }
  /// S (rank x tangent size) with S^T S = H_prior, and e0 = S^-T b_prior (pseudo-inverse).
  const Eigen::MatrixXd& sqrtHessian() const { return S_; }
  const Eigen::VectorXd& residualAtLinearization() const { return e0_; }
  /// Linearisation point of a kept block (its ambient values at addResidualBlock time).
  const std::vector<double>& linearizationPoint(const double* block) const;

  /// A kept 3-vector block whose states moved by x -> M x + k (M invertible).
  struct BlockMap {
    const double* block = nullptr;
    Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
    Eigen::Vector3d k = Eigen::Vector3d::Zero();
  };
  /// The affine map of a position scaled about `centre`: x -> centre + s (x - centre).
  static BlockMap scaling(const double* block, const Eigen::Vector3d& centre, double s);

  /// This prior for states moved by `maps` (e.g. the window rescaled: positions by scaling(),
  /// terrain planes by factors::terrainScaling). The copy holds the same shape in the new
  /// coordinates: its linearisation points move with the states and its Jacobian columns of
  /// those blocks are multiplied by M^-1, so at the moved states it has the residual this one
  /// has at the old ones. Blocks not kept, or not 3-vectors, are ignored.
  std::shared_ptr<const MarginalizationInfo> mapped(const std::vector<BlockMap>& maps) const;

 private:
  struct Block {
    int ambient = 0;
    int tangent = 0;
    bool quaternion = false;
    bool dropped = false;
    std::vector<double> x0;
  };
  struct Linearized {
    std::vector<double*> blocks;
    Eigen::VectorXd residual;
    std::vector<Eigen::MatrixXd> jacobians_ambient;
  };

  Options options_;
  std::unordered_map<const double*, Block> blocks_;
  std::vector<double*> order_;  // first-appearance order of all blocks
  std::vector<Linearized> residuals_;
  std::vector<double*> kept_;
  Eigen::MatrixXd H_prior_, S_;
  Eigen::VectorXd b_prior_, e0_;
  friend class MarginalizationFactor;
};

/// The prior as a Ceres cost: r = S dx + e0 with dx = x boxminus x0 per kept block (Euclidean:
/// x - x0; quaternion: Ceres's half-angle Log((q q0^-1)), shortest rotation). Its value and
/// Jacobian are exact at any x (not only at x0); H and b stay those of the linearisation point.
class MarginalizationFactor final : public ceres::CostFunction {
 public:
  explicit MarginalizationFactor(std::shared_ptr<const MarginalizationInfo> info);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::shared_ptr<const MarginalizationInfo> info_;
};

}  // namespace ovo::factors
