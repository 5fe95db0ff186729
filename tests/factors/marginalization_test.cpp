#include "factors/marginalization.hpp"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <set>

#include "factors/bearing_factor.hpp"
#include "factors/gyro_preintegration.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/pose_prior_factor.hpp"
#include "factors/terrain_plane_factor.hpp"
#include "tests/factors/factor_test_util.hpp"
#include "tests/test_support.hpp"

namespace ovo::factors {
namespace {

using RowMajor3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

// r = A (x - z): an absolute measurement of a 3-D state.
class AbsoluteFactor final : public ceres::SizedCostFunction<3, 3> {
 public:
  AbsoluteFactor(const Mat3& A, const Vec3& z) : A_(A), z_(z) {}
  bool Evaluate(double const* const* x, double* r, double** J) const override {
    Eigen::Map<Vec3> res(r);
    res = A_ * (Eigen::Map<const Vec3>(x[0]) - z_);
    if (J && J[0]) Eigen::Map<RowMajor3>{J[0]} = A_;
    return true;
  }

 private:
  Mat3 A_;
  Vec3 z_;
};

// r = A (x_j - x_i - z): a relative measurement between two 3-D states.
class RelativeFactor final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  RelativeFactor(const Mat3& A, const Vec3& z) : A_(A), z_(z) {}
  bool Evaluate(double const* const* x, double* r, double** J) const override {
    Eigen::Map<Vec3> res(r);
    res = A_ * (Eigen::Map<const Vec3>(x[1]) - Eigen::Map<const Vec3>(x[0]) - z_);
    if (J && J[0]) Eigen::Map<RowMajor3>{J[0]} = -A_;
    if (J && J[1]) Eigen::Map<RowMajor3>{J[1]} = A_;
    return true;
  }

 private:
  Mat3 A_;
  Vec3 z_;
};

struct Factor {
  std::shared_ptr<ceres::CostFunction> cost;
  std::vector<double*> blocks;
};

void solve(const std::vector<Factor>& factors) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (const Factor& f : factors) problem.AddResidualBlock(f.cost.get(), nullptr, f.blocks);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 200;
  so.function_tolerance = 0.0;
  so.gradient_tolerance = 1e-20;
  so.parameter_tolerance = 1e-20;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
}

// A chain of 3-D states x_k with absolute and relative measurements, and one landmark l_k per
// state (anchored at x_k, also measured from x_{k+1}). All factors are linear, so the windowed
// answer with the marginalisation prior must equal the batch answer exactly.
class LinearChain {
 public:
  static constexpr int kStates = 12;
  explicit LinearChain(unsigned seed) : rng_(seed) {
    std::normal_distribution<double> n(0.0, 1.0);
    const auto noisy = [&](const Vec3& v, double s) {
      return Vec3(v + s * ovo::test::draw3(n, rng_));
    };
    const auto whitening = [&]() { return Mat3(Mat3::Identity() * 2.0 + 0.5 * Mat3::Random()); };
    for (int k = 0; k < kStates; ++k) {
      x_true_[k] = Vec3(k, 0.3 * k * k / kStates, std::sin(k));
      l_true_[k] = x_true_[k] + Vec3(1.0, -2.0, 0.5);
    }
    for (int k = 0; k < kStates; ++k) {
      std::vector<Factor> fs;
      if (k == 0)
        fs.push_back({std::make_shared<AbsoluteFactor>(whitening(), noisy(x_true_[0], 0.1)),
                      {x_[0].data()}});
      if (k % 3 == 2)
        fs.push_back({std::make_shared<AbsoluteFactor>(whitening(), noisy(x_true_[k], 0.3)),
                      {x_[k].data()}});
      if (k >= 1)
        fs.push_back({std::make_shared<RelativeFactor>(whitening(),
                                                       noisy(x_true_[k] - x_true_[k - 1], 0.05)),
                      {x_[k - 1].data(), x_[k].data()}});
      if (k >= 2)
        fs.push_back({std::make_shared<RelativeFactor>(whitening(),
                                                       noisy(x_true_[k] - x_true_[k - 2], 0.08)),
                      {x_[k - 2].data(), x_[k].data()}});
      fs.push_back(
          {std::make_shared<RelativeFactor>(whitening(), noisy(l_true_[k] - x_true_[k], 0.1)),
           {x_[k].data(), l_[k].data()}});
      if (k >= 1)
        fs.push_back(
            {std::make_shared<RelativeFactor>(whitening(), noisy(l_true_[k - 1] - x_true_[k], 0.1)),
             {x_[k].data(), l_[k - 1].data()}});
      arriving_.push_back(fs);
    }
  }
  void resetStates() {
    std::normal_distribution<double> n(0.0, 0.5);
    for (int k = 0; k < kStates; ++k) {
      for (int i = 0; i < 3; ++i) {
        x_[k][i] = x_true_[k][i] + n(rng_);
        l_[k][i] = l_true_[k][i] + n(rng_);
      }
    }
  }
  std::vector<Factor> allFactors() const {
    std::vector<Factor> out;
    for (const auto& fs : arriving_) out.insert(out.end(), fs.begin(), fs.end());
    return out;
  }

  std::mt19937 rng_;
  std::array<Vec3, kStates> x_true_, l_true_;
  std::array<std::array<double, 3>, kStates> x_{}, l_{};
  std::vector<std::vector<Factor>> arriving_;  // factors that become complete when x_k arrives
};

// Slides a window of `window` states over the chain, marginalising the oldest state with the
// landmark it anchors; returns after the last state with the window solved.
void runSlidingWindow(LinearChain& chain, int window, bool solve_before_marginalizing) {
  std::vector<Factor> active;
  for (int k = 0; k < LinearChain::kStates; ++k) {
    active.insert(active.end(), chain.arriving_[k].begin(), chain.arriving_[k].end());
    const int oldest = k - window;
    if (oldest < 0) continue;
    if (solve_before_marginalizing) solve(active);
    const std::set<const double*> drop = {chain.x_[oldest].data(), chain.l_[oldest].data()};
    auto info = std::make_shared<MarginalizationInfo>();
    std::vector<Factor> remaining;
    for (const Factor& f : active) {
      std::vector<int> drop_idx;
      for (std::size_t i = 0; i < f.blocks.size(); ++i)
        if (drop.count(f.blocks[i])) drop_idx.push_back(static_cast<int>(i));
      if (drop_idx.empty()) {
        remaining.push_back(f);
      } else {
        ASSERT_TRUE(info->addResidualBlock(f.cost.get(), nullptr, f.blocks, drop_idx));
      }
    }
    ASSERT_TRUE(info->marginalize());
    EXPECT_EQ(info->droppedBlocks().size(), 2u);
    remaining.push_back({std::make_shared<MarginalizationFactor>(info), info->keptBlocks()});
    active = std::move(remaining);
  }
  solve(active);
}

TEST(Marginalization, LinearChainWindowWithPriorEqualsBatch) {
  for (const bool solve_first : {true, false}) {
    SCOPED_TRACE(solve_first ? "solved before each marginalisation"
                             : "marginalised at the initial guess");
    LinearChain chain(21);
    chain.resetStates();
    solve(chain.allFactors());
    const auto x_batch = chain.x_;
    const auto l_batch = chain.l_;

    chain.resetStates();
    const int window = 4;
    runSlidingWindow(chain, window, solve_first);
    // The window's last states (marginalised 8 times) and their landmarks equal the batch answer.
    for (int k = LinearChain::kStates - window; k < LinearChain::kStates; ++k) {
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(chain.x_[k][i], x_batch[k][i], 1e-9) << "state " << k;
        EXPECT_NEAR(chain.l_[k][i], l_batch[k][i], 1e-9) << "landmark " << k;
      }
    }
  }
}

// Nonlinear window of three keyframes with gyro, bias, bearing, LiDAR and pose-prior factors;
// keyframe 0 (pose, bias) and the landmark it anchors are marginalised.
class NonlinearWindow : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(31);
    T_B_C_ = testing::randomPose(rng, 0.5, 0.1);
    T_B_L_ = testing::randomPose(rng, 0.5, 0.2);
    for (int k = 0; k < 3; ++k) {
      T_W_B_[k] = SE3::Identity();
      T_W_B_[k].linear() = so3::exp(Vec3(0.05 * k, -0.1 * k, 0.3 * k));
      T_W_B_[k].translation() = Vec3(0.5 * k, 0.1 * k, 0.0);
      quatToBlock(Quat(T_W_B_[k].rotation()), q_[k].data());
      for (int i = 0; i < 3; ++i) p_[k][i] = T_W_B_[k].translation()[i] + 0.02 * (i - 1);
      b_[k] = {0.01, -0.02, 0.005};
    }
    // Landmarks: A anchored at keyframe 0, B anchored at keyframe 1.
    const Vec3 pA_W(3.0, 1.0, 0.5), pB_W(2.0, -1.5, 1.0);
    const auto bearingIn = [&](int k, const Vec3& p_W) {
      return Vec3(((T_W_B_[k] * T_B_C_).inverse() * p_W).normalized());
    };
    rhoA_[0] = 1.0 / ((T_W_B_[0] * T_B_C_).inverse() * pA_W).norm() * 1.05;
    rhoB_[0] = 1.0 / ((T_W_B_[1] * T_B_C_).inverse() * pB_W).norm() * 0.97;

    std::vector<ImuSample> samples;
    for (Timestamp t = 0; t <= 2'100'000'000; t += 5'000'000) {
      ImuSample s;
      s.t_ns = t;
      s.gyro_radps =
          Vec3(0.05, -0.1, 0.3) + Vec3(0.01, -0.02, 0.005) + 0.02 * Vec3(std::sin(t * 1e-9), 0, 0);
      samples.push_back(s);
    }
    const auto pre01 =
        std::make_shared<GyroPreintegration>(samples, 0, 1'000'000'000, Vec3::Zero());
    const auto pre12 =
        std::make_shared<GyroPreintegration>(samples, 1'000'000'000, 2'000'000'000, Vec3::Zero());
    const auto huber = std::make_shared<ceres::HuberLoss>(1.0);
    const double sigma_bearing = 0.003;
    const Vec3 bA0 = bearingIn(0, pA_W), bB1 = bearingIn(1, pB_W);
    const auto noisy = [](const Vec3& b, double e) {
      return Vec3((b + Vec3(e, -e, 0.5 * e)).normalized());
    };
    const Mat6 gauge = PosePriorFactor::gaugeInformation(0.01, 0.01, 0.05);
    add(std::make_shared<PosePriorFactor>(T_W_B_[0], gauge), nullptr, {q_[0].data(), p_[0].data()});
    add(std::make_shared<GyroFactor>(pre01), nullptr, {q_[0].data(), q_[1].data(), b_[0].data()});
    add(std::make_shared<GyroFactor>(pre12), nullptr, {q_[1].data(), q_[2].data(), b_[1].data()});
    add(std::make_shared<BiasRandomWalkFactor>(2e-4, 1.0), nullptr, {b_[0].data(), b_[1].data()});
    add(std::make_shared<BearingFactor>(bA0, noisy(bearingIn(1, pA_W), 0.004), T_B_C_,
                                        sigma_bearing),
        huber, {q_[0].data(), p_[0].data(), q_[1].data(), p_[1].data(), rhoA_.data()});
    add(std::make_shared<BearingFactor>(bA0, noisy(bearingIn(2, pA_W), -0.002), T_B_C_,
                                        sigma_bearing),
        huber, {q_[0].data(), p_[0].data(), q_[2].data(), p_[2].data(), rhoA_.data()});
    add(std::make_shared<BearingFactor>(bB1, noisy(bearingIn(0, pB_W), 0.001), T_B_C_,
                                        sigma_bearing),
        huber, {q_[1].data(), p_[1].data(), q_[0].data(), p_[0].data(), rhoB_.data()});
    add(std::make_shared<BearingFactor>(bB1, noisy(bearingIn(2, pB_W), 0.002), T_B_C_,
                                        sigma_bearing),
        huber, {q_[1].data(), p_[1].data(), q_[2].data(), p_[2].data(), rhoB_.data()});
    const double range = ((T_W_B_[1] * T_B_L_).inverse() * pA_W).norm() + 0.05;
    add(std::make_shared<LidarRangeFactor>(bA0, range, T_B_C_, T_B_L_, 0.03), nullptr,
        {q_[0].data(), p_[0].data(), q_[1].data(), p_[1].data(), rhoA_.data()});
  }

  void add(std::shared_ptr<ceres::CostFunction> cost, std::shared_ptr<ceres::LossFunction> loss,
           std::vector<double*> blocks) {
    factors_.push_back({std::move(cost), std::move(loss), std::move(blocks)});
  }
  bool isQuat(const double* p) const {
    return p == q_[0].data() || p == q_[1].data() || p == q_[2].data();
  }
  std::set<const double*> dropped() const {
    return {q_[0].data(), p_[0].data(), b_[0].data(), rhoA_.data()};
  }
  /// The prior of keyframe 0 and landmark A (every factor touching them), null on failure.
  std::shared_ptr<const MarginalizationInfo> marginalizeKeyframe0() const {
    auto info = std::make_shared<MarginalizationInfo>();
    for (int k = 0; k < 3; ++k) info->setQuaternionBlock(q_[k].data());
    const auto drop = dropped();
    for (const LossyFactor& f : factors_) {
      std::vector<int> drop_idx;
      for (std::size_t i = 0; i < f.blocks.size(); ++i)
        if (drop.count(f.blocks[i])) drop_idx.push_back(static_cast<int>(i));
      if (drop_idx.empty()) continue;
      if (!info->addResidualBlock(f.cost.get(), f.loss.get(), f.blocks, drop_idx)) return nullptr;
    }
    if (!info->marginalize()) return nullptr;
    return info;
  }

  /// The prior's kept states moved off its linearisation point: quaternions by a random rotation
  /// of up to 0.1 (tangent units), the other blocks by +0.05 per value.
  std::vector<std::vector<double>> awayFromLinearization(const MarginalizationInfo& info,
                                                         unsigned seed) const {
    std::mt19937 rng(seed);
    ceres::EigenQuaternionManifold qm;
    std::vector<std::vector<double>> values;
    for (double* p : info.keptBlocks()) {
      std::vector<double> v = info.linearizationPoint(p);
      if (isQuat(p)) {
        const Vec3 d = testing::randomVec(rng, 0.1);
        std::vector<double> out(4);
        qm.Plus(v.data(), d.data(), out.data());
        v = out;
      } else {
        for (double& x : v) x += 0.05;
      }
      values.push_back(v);
    }
    return values;
  }

  struct LossyFactor {
    std::shared_ptr<ceres::CostFunction> cost;
    std::shared_ptr<ceres::LossFunction> loss;
    std::vector<double*> blocks;
  };
  SE3 T_B_C_, T_B_L_;
  std::array<SE3, 3> T_W_B_;
  std::array<std::array<double, 4>, 3> q_{};
  std::array<std::array<double, 3>, 3> p_{}, b_{};
  std::array<double, 1> rhoA_{}, rhoB_{};
  std::vector<LossyFactor> factors_;
};

TEST_F(NonlinearWindow, PriorMatchesDenseSchurComplementOfCeresJacobian) {
  MarginalizationInfo info;
  for (int k = 0; k < 3; ++k) info.setQuaternionBlock(q_[k].data());
  // Reference: Ceres's own (loss-corrected, tangent-space) Jacobian of the same residual blocks.
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::EigenQuaternionManifold quat_manifold;
  const auto drop = dropped();
  for (const LossyFactor& f : factors_) {
    std::vector<int> drop_idx;
    for (std::size_t i = 0; i < f.blocks.size(); ++i)
      if (drop.count(f.blocks[i])) drop_idx.push_back(static_cast<int>(i));
    if (drop_idx.empty()) continue;  // stays in the window, not part of the prior
    ASSERT_TRUE(info.addResidualBlock(f.cost.get(), f.loss.get(), f.blocks, drop_idx));
    problem.AddResidualBlock(f.cost.get(), f.loss.get(), f.blocks);
  }
  for (int k = 0; k < 3; ++k) problem.SetManifold(q_[k].data(), &quat_manifold);
  ASSERT_TRUE(info.marginalize());

  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = info.droppedBlocks();
  int m = 0;
  for (const double* p : eo.parameter_blocks) m += isQuat(p) ? 3 : problem.ParameterBlockSize(p);
  for (double* p : info.keptBlocks()) eo.parameter_blocks.push_back(p);
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  ASSERT_TRUE(problem.Evaluate(eo, nullptr, &residuals, nullptr, &crs));
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i) J(r, crs.cols[i]) = crs.values[i];
  const Eigen::VectorXd res = Eigen::Map<Eigen::VectorXd>(residuals.data(), residuals.size());
  const Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::VectorXd g = J.transpose() * res;
  const int n = static_cast<int>(H.rows()), r = n - m;
  const Eigen::MatrixXd Hmm_inv = H.topLeftCorner(m, m).inverse();
  const Eigen::MatrixXd H_ref =
      H.bottomRightCorner(r, r) - H.bottomLeftCorner(r, m) * Hmm_inv * H.topRightCorner(m, r);
  const Eigen::VectorXd b_ref = g.tail(r) - H.bottomLeftCorner(r, m) * Hmm_inv * g.head(m);

  const double h_scale = H_ref.cwiseAbs().maxCoeff();
  EXPECT_LT((info.priorHessian() - H_ref).cwiseAbs().maxCoeff(), 1e-9 * h_scale);
  EXPECT_LT((info.priorGradient() - b_ref).cwiseAbs().maxCoeff(),
            1e-9 * std::max(1.0, b_ref.cwiseAbs().maxCoeff()));
  const Eigen::MatrixXd& S = info.sqrtHessian();
  EXPECT_LT((S.transpose() * S - H_ref).cwiseAbs().maxCoeff(), 1e-9 * h_scale);
  EXPECT_LT((S.transpose() * info.residualAtLinearization() - b_ref).cwiseAbs().maxCoeff(),
            1e-7 * std::max(1.0, b_ref.cwiseAbs().maxCoeff()));
}

TEST_F(NonlinearWindow, PriorResidualAndJacobianMatchNumericAtAndAwayFromLinearization) {
  const auto info = marginalizeKeyframe0();
  ASSERT_TRUE(info);
  const MarginalizationFactor prior(info);
  std::vector<std::vector<double>> values;
  std::vector<bool> is_quat;
  for (double* p : info->keptBlocks()) {
    values.push_back(info->linearizationPoint(p));
    is_quat.push_back(isQuat(p));
  }
  EXPECT_EQ(static_cast<int>(values.size()), 6);  // q1 p1 b1 q2 p2 rhoB
  // At x0 the residual is e0, and the Jacobian is S in tangent space.
  const Eigen::VectorXd r0 = testing::evaluate(prior, values);
  EXPECT_LT((r0 - info->residualAtLinearization()).norm(), 1e-12);
  testing::expectJacobiansMatch(prior, values, is_quat, 1e-6);
  // Away from x0 the boxminus is still differentiated exactly.
  std::mt19937 rng(32);
  ceres::EigenQuaternionManifold qm;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (is_quat[i]) {
      const Vec3 d = testing::randomVec(rng, 0.2);
      std::vector<double> out(4);
      qm.Plus(values[i].data(), d.data(), out.data());
      values[i] = out;
    } else {
      for (double& v : values[i]) v += 0.1;
    }
  }
  testing::expectJacobiansMatch(prior, values, is_quat, 1e-6);
}

TEST_F(NonlinearWindow, ScaledPriorHasTheSameResidualAtTheScaledPositions) {
  const auto info = marginalizeKeyframe0();
  ASSERT_TRUE(info);
  const Vec3 centre(0.3, -0.2, 0.1);
  const double s = 1.7;
  const auto scaled = info->mapped({MarginalizationInfo::scaling(p_[1].data(), centre, s),
                                    MarginalizationInfo::scaling(p_[2].data(), centre, s)});

  // Some state away from the linearisation point, and the same state scaled about the centre.
  const std::vector<std::vector<double>> values = awayFromLinearization(*info, 33);
  std::vector<std::vector<double>> values_scaled;
  std::vector<bool> is_quat;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double* p = info->keptBlocks()[i];
    std::vector<double> v = values[i];
    const bool is_position = p == p_[1].data() || p == p_[2].data();
    if (is_position)
      for (int k = 0; k < 3; ++k) v[k] = centre[k] + s * (v[k] - centre[k]);
    values_scaled.push_back(v);
    is_quat.push_back(isQuat(p));
  }
  const Eigen::VectorXd r = testing::evaluate(MarginalizationFactor(info), values);
  const Eigen::VectorXd r_scaled = testing::evaluate(MarginalizationFactor(scaled), values_scaled);
  EXPECT_LT((r - r_scaled).norm(), 1e-9 * std::max(1.0, r.norm()));
  // The scaled positions' linearisation points moved with them; the rest did not.
  for (double* p : info->keptBlocks()) {
    const auto& x0 = info->linearizationPoint(p);
    const auto& x0_scaled = scaled->linearizationPoint(p);
    const bool is_position = p == p_[1].data() || p == p_[2].data();
    for (std::size_t k = 0; k < x0.size(); ++k)
      EXPECT_NEAR(x0_scaled[k], is_position ? centre[k] + s * (x0[k] - centre[k]) : x0[k], 1e-12);
  }
  // Its Hessian and gradient are the old ones with the position rows and columns over s.
  Eigen::VectorXd d(info->priorHessian().rows());
  int offset = 0;
  for (double* p : info->keptBlocks()) {
    const int n = isQuat(p) ? 3 : static_cast<int>(info->linearizationPoint(p).size());
    const bool is_position = p == p_[1].data() || p == p_[2].data();
    d.segment(offset, n).setConstant(is_position ? 1.0 / s : 1.0);
    offset += n;
  }
  const Eigen::MatrixXd H_expected = d.asDiagonal() * info->priorHessian() * d.asDiagonal();
  EXPECT_LT((scaled->priorHessian() - H_expected).cwiseAbs().maxCoeff(),
            1e-12 * H_expected.cwiseAbs().maxCoeff());
  EXPECT_LT((scaled->priorGradient() - d.asDiagonal() * info->priorGradient()).norm(),
            1e-12 * std::max(1.0, info->priorGradient().norm()));
  testing::expectJacobiansMatch(MarginalizationFactor(scaled), values_scaled, is_quat, 1e-6);
  // The unscaled prior at the scaled positions is far off: the residual check is not vacuous.
  EXPECT_GT((testing::evaluate(MarginalizationFactor(info), values_scaled) - r).norm(), 1e-3);
}

TEST_F(NonlinearWindow, ScaledPriorMapsTerrainPlanesAsTheirPointsScale) {
  // A kept 3-vector taken as a terrain plane (the prior does not know what its blocks mean): at
  // the scaled positions and the plane scaled as factors::scaleTerrain (slopes kept, height over
  // the centre times s) the scaled prior has the old residual.
  const auto info = marginalizeKeyframe0();
  ASSERT_TRUE(info);
  const Vec3 centre(0.3, -0.2, 0.1);
  const double s = 0.8;
  const std::vector<MarginalizationInfo::BlockMap> positions = {
      MarginalizationInfo::scaling(p_[1].data(), centre, s),
      MarginalizationInfo::scaling(p_[2].data(), centre, s)};
  const TerrainScaling terrain = terrainScaling(centre, s);
  std::vector<MarginalizationInfo::BlockMap> with_terrain = positions;
  with_terrain.push_back({b_[1].data(), terrain.M, terrain.k});
  const auto scaled = info->mapped(with_terrain);
  const std::vector<std::vector<double>> values = awayFromLinearization(*info, 34);
  std::vector<std::vector<double>> values_scaled;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double* p = info->keptBlocks()[i];
    std::vector<double> v = values[i];
    if (p == p_[1].data() || p == p_[2].data())
      for (int k = 0; k < 3; ++k) v[k] = centre[k] + s * (v[k] - centre[k]);
    if (p == b_[1].data()) scaleTerrain(v.data(), centre, s);
    values_scaled.push_back(v);
  }
  ASSERT_TRUE(std::find(info->keptBlocks().begin(), info->keptBlocks().end(), b_[1].data()) !=
              info->keptBlocks().end());
  const Eigen::VectorXd r = testing::evaluate(MarginalizationFactor(info), values);
  const Eigen::VectorXd r_scaled = testing::evaluate(MarginalizationFactor(scaled), values_scaled);
  EXPECT_GT(r.norm(), 1e-3);
  EXPECT_LT((r - r_scaled).norm(), 1e-9 * std::max(1.0, r.norm()));
  // Not mapping the plane leaves its height over the centre unscaled: another residual.
  const auto positions_only = info->mapped(positions);
  const Eigen::VectorXd r_unmapped =
      testing::evaluate(MarginalizationFactor(positions_only), values_scaled);
  EXPECT_GT((r - r_unmapped).norm(), 1e-6);
}

}  // namespace
}  // namespace ovo::factors
