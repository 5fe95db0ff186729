// A keyframe's pose covariance from the window's factors (ceres::Covariance).
#include "estimator/window/covariance.hpp"

#include <ceres/ceres.h>

#include <unordered_set>
#include <utility>

#include "estimator/window/solve.hpp"

namespace ovo::estimator {

std::optional<Mat6> poseCovariance(std::vector<FactorSpec> factors,
                                   const std::vector<Keyframe*>& keyframes,
                                   const WindowModel& model, Keyframe& kf) {
  double* q = tiedRotations(model) ? kf.q_W_G : kf.q_W_B;
  std::unordered_set<const double*> used;
  for (const FactorSpec& f : factors) used.insert(f.blocks.begin(), f.blocks.end());
  if (!used.count(q) || !used.count(kf.p_W_B)) return std::nullopt;
  ceres::Problem problem;
  addFactorsToProblem(factors, keyframes, model, used, problem);

  ceres::Covariance::Options options;
  options.algorithm_type = ceres::DENSE_SVD;
  options.null_space_rank = -1;  // drop what the factors do not observe
  options.num_threads = 1;
  ceres::Covariance covariance(options);
  const std::vector<const double*> blocks = {q, kf.p_W_B};
  if (!covariance.Compute(blocks, &problem)) return std::nullopt;
  Mat6 tangent;
  if (!covariance.GetCovarianceMatrixInTangentSpace(blocks, tangent.data())) return std::nullopt;
  // Ceres' quaternion manifold: Plus(q, d) = [cos |d|, sin |d| d / |d|] * q, a rotation by the
  // rotation vector 2 d on the left: phi = 2 d. (Eigen's storage is column-major; the matrix is
  // symmetric.)
  Mat6 J = Mat6::Identity();
  J.topLeftCorner<3, 3>() *= 2.0;
  const Mat6 out = J * tangent * J.transpose();
  if (!out.allFinite()) return std::nullopt;
  return out;
}

}  // namespace ovo::estimator
