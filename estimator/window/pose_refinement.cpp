// Motion-only refinement of one frame's pose against fixed landmarks.
#include "estimator/window/pose_refinement.hpp"

#include <ceres/loss_function.h>
#include <ceres/sized_cost_function.h>

#include <cmath>
#include <memory>

#include "estimator/window/landmark_schur.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/parameterization.hpp"
#include "factors/pose_prior_factor.hpp"

namespace ovo::estimator {
namespace {

// A bearing factor whose landmark is held (its anchor blocks are constants of the factor): a
// residual on the frame's pose alone, so that the solve has two blocks, not four per point.
class HeldPointBearing final : public ceres::SizedCostFunction<2, 4, 3> {
 public:
  HeldPointBearing(std::unique_ptr<factors::BearingFactor> factor, const double* q_a,
                   const double* p_a, const double* rho)
      : factor_(std::move(factor)), q_a_(q_a), p_a_(p_a), rho_(rho) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* blocks[5] = {q_a_, p_a_, parameters[0], parameters[1], rho_};
    double* jac[5] = {nullptr, nullptr, jacobians ? jacobians[0] : nullptr,
                      jacobians ? jacobians[1] : nullptr, nullptr};
    return factor_->Evaluate(blocks, residuals, jacobians ? jac : nullptr);
  }

 private:
  std::unique_ptr<factors::BearingFactor> factor_;
  const double *q_a_, *p_a_, *rho_;
};

}  // namespace

std::optional<PoseRefinement> refinePose(const std::vector<Vec3>& points_W,
                                         const std::vector<Vec3>& bearings_C,
                                         const std::vector<SE3>& cameras_B, const SE3& T_W_B_init,
                                         const std::optional<Mat3>& R_W_B_prior,
                                         double prior_sigma_rad, const WindowModel& model,
                                         int max_iterations, double outlier_rad) {
  const std::size_t n = points_W.size();
  if (n < 3 || bearings_C.size() != n || (!cameras_B.empty() && cameras_B.size() != n))
    return std::nullopt;
  const auto camera = [&](std::size_t i) -> const SE3& {
    return cameras_B.empty() ? model.T_B_C : cameras_B[i];
  };
  // Each point as an anchor at the world origin with identity rotation: b_a = p_W - t_B_C
  // direction is awkward; instead anchor it in a virtual body frame at p_W - R t_B_C.
  struct Anchor {
    double q[4] = {0, 0, 0, 1};
    double p[3] = {0, 0, 0};
    double rho[1] = {1.0};
    Vec3 bearing = Vec3::UnitZ();
  };
  std::vector<Anchor> anchors(n);
  const Mat3 R_B_C = model.T_B_C.linear();
  const Vec3 t_B_C = model.T_B_C.translation();
  for (std::size_t i = 0; i < n; ++i) {
    // Virtual anchor body with R_W_Ba = R_C_B (so that R_W_Ba R_B_C = I): its camera sits at
    // p_W_Ba + R_W_Ba t_B_C; put that camera at the origin and the point at distance 1/rho.
    const Mat3 R_W_Ba = R_B_C.transpose();
    Vec3 d = points_W[i];
    const double dist = d.norm();
    if (!(dist > 1e-6)) return std::nullopt;
    factors::quatToBlock(Quat(R_W_Ba), anchors[i].q);
    const Vec3 p_W_Ba = -R_W_Ba * t_B_C;
    for (int k = 0; k < 3; ++k) anchors[i].p[k] = p_W_Ba[k];
    anchors[i].bearing = d / dist;
    anchors[i].rho[0] = 1.0 / dist;
  }
  double q[4], p[3];
  factors::quatToBlock(Quat(T_W_B_init.linear()).normalized(), q);
  for (int k = 0; k < 3; ++k) p[k] = T_W_B_init.translation()[k];

  // The window's own minimiser (Ceres' LM steps; landmark_schur.hpp) on the pose's two blocks.
  ceres::HuberLoss huber(model.bearing_huber);
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  costs.reserve(n + 1);
  for (std::size_t i = 0; i < n; ++i) {
    // (The virtual anchor's camera is the rig's; the frame's is at its sighting's row.)
    auto factor = camera(i).matrix() == model.T_B_C.matrix()
                      ? std::make_unique<factors::BearingFactor>(
                            anchors[i].bearing, bearings_C[i], model.T_B_C, model.bearing_sigma_rad)
                      : std::make_unique<factors::BearingFactor>(
                            anchors[i].bearing, bearings_C[i], model.T_B_C, camera(i),
                            Mat2::Identity() / model.bearing_sigma_rad);
    costs.push_back(std::make_unique<HeldPointBearing>(std::move(factor), anchors[i].q,
                                                       anchors[i].p, anchors[i].rho));
  }
  const std::vector<double*> pose = {q, p};
  std::vector<LmResidual> residuals;
  residuals.reserve(n + 1);
  for (std::size_t i = 0; i < n; ++i) residuals.push_back({costs[i].get(), &huber, &pose});
  if (R_W_B_prior) {
    factors::Mat6 info = factors::Mat6::Zero();
    info.topLeftCorner<3, 3>() = Mat3::Identity() / (prior_sigma_rad * prior_sigma_rad);
    SE3 T0 = SE3::Identity();
    T0.linear() = *R_W_B_prior;
    costs.push_back(std::make_unique<factors::PosePriorFactor>(T0, info));
    residuals.push_back({costs.back().get(), nullptr, &pose});
  }
  std::unordered_map<const double*, LmBlockInfo> info;
  info[q].quaternion = true;
  LmOptions lo;
  lo.max_iterations = max_iterations;
  if (solveLandmarkSchur(residuals, info, lo).failed) return std::nullopt;

  PoseRefinement out;
  out.T_W_B = SE3::Identity();
  out.T_W_B.linear() = factors::quatFromBlock(q).toRotationMatrix();
  out.T_W_B.translation() = Vec3(p[0], p[1], p[2]);
  if (!allFinite(out.T_W_B)) return std::nullopt;
  out.inlier.resize(n, 0);
  const double cos_max = std::cos(outlier_rad);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 p_C = (out.T_W_B * camera(i)).inverse() * points_W[i];
    const double norm = p_C.norm();
    if (norm > 0.0 && p_C.dot(bearings_C[i]) / norm > cos_max) {
      out.inlier[i] = 1;
      ++out.num_inliers;
    }
  }
  return out;
}

}  // namespace ovo::estimator
