#include "eval/align.hpp"

#include <Eigen/SVD>

namespace ovo::eval {

std::optional<AlignMode> parseAlignMode(const std::string& name) {
  if (name == "none") return AlignMode::kNone;
  if (name == "se3") return AlignMode::kSE3;
  if (name == "sim3") return AlignMode::kSim3;
  return std::nullopt;
}

std::string alignModeName(AlignMode mode) {
  switch (mode) {
    case AlignMode::kNone:
      return "none";
    case AlignMode::kSE3:
      return "se3";
    case AlignMode::kSim3:
      return "sim3";
  }
  return "?";
}

SE3 Similarity::apply(const SE3& T) const {
  SE3 out = SE3::Identity();
  out.linear() = R * T.linear();
  out.translation() = apply(Vec3(T.translation()));
  return out;
}

std::optional<Similarity> umeyama(const std::vector<Vec3>& from, const std::vector<Vec3>& to,
                                  bool with_scale) {
  const std::size_t n = from.size();
  if (n < 3 || to.size() != n) return std::nullopt;
  // Means (eqs. 34, 35), variance of `from` (eq. 36), covariance (eq. 38).
  Vec3 mean_from = Vec3::Zero(), mean_to = Vec3::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mean_from += from[i];
    mean_to += to[i];
  }
  mean_from /= static_cast<double>(n);
  mean_to /= static_cast<double>(n);
  double sigma2_from = 0.0;
  Mat3 cov = Mat3::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 a = from[i] - mean_from;
    sigma2_from += a.squaredNorm();
    cov += (to[i] - mean_to) * a.transpose();
  }
  sigma2_from /= static_cast<double>(n);
  cov /= static_cast<double>(n);
  if (!(sigma2_from > 0.0) || !cov.allFinite()) return std::nullopt;

  const Eigen::JacobiSVD<Mat3> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 d = svd.singularValues();
  // Rank < 2: the rotation is not determined (all points on a line).
  if (!(d(1) > 1e-12 * std::max(1.0, d(0)))) return std::nullopt;
  Mat3 S = Mat3::Identity();  // eq. 43
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;
  Similarity out;
  out.R = svd.matrixU() * S * svd.matrixV().transpose();                      // eq. 40
  out.scale = with_scale ? (d.asDiagonal() * S).trace() / sigma2_from : 1.0;  // eq. 42
  out.t = mean_to - out.scale * out.R * mean_from;                            // eq. 41
  if (!out.R.allFinite() || !out.t.allFinite() || !(out.scale > 0.0)) return std::nullopt;
  return out;
}

std::optional<Similarity> alignTrajectories(const Trajectory& ref, const Trajectory& est,
                                            AlignMode mode) {
  if (ref.size() != est.size()) return std::nullopt;
  if (mode == AlignMode::kNone) return Similarity{};
  std::vector<Vec3> from, to;
  from.reserve(est.size());
  to.reserve(ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) {
    from.push_back(est[i].T_W_B.translation());
    to.push_back(ref[i].T_W_B.translation());
  }
  return umeyama(from, to, mode == AlignMode::kSim3);
}

std::optional<Similarity> alignFirstPose(const Trajectory& ref, const Trajectory& est) {
  if (ref.empty() || est.empty()) return std::nullopt;
  const SE3& T_ref = ref.front().T_W_B;
  const SE3& T_est = est.front().T_W_B;
  Similarity out;
  out.R = T_ref.linear() * T_est.linear().transpose();
  out.t = T_ref.translation() - out.R * T_est.translation();
  return out;
}

Trajectory transformed(const Trajectory& est, const Similarity& S) {
  Trajectory out = est;
  for (auto& pose : out) pose.T_W_B = S.apply(pose.T_W_B);
  return out;
}

}  // namespace ovo::eval
