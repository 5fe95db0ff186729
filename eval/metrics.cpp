#include "eval/metrics.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace ovo::eval {

namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// Rotation angle of a (nearly) orthonormal matrix, accurate near 0 and pi.
double rotationAngleRad(const Mat3& R) {
  const Vec3 axis(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  const double c = 0.5 * (R.trace() - 1.0);
  return std::atan2(0.5 * axis.norm(), c);
}

// (A^-1 B) with the rigid inverse (rotation transposed), as evo's relative_se3.
Eigen::Matrix4d relative(const SE3& A, const SE3& B) {
  Eigen::Matrix4d A_inv = Eigen::Matrix4d::Identity();
  A_inv.topLeftCorner<3, 3>() = A.linear().transpose();
  A_inv.topRightCorner<3, 1>() = -A.linear().transpose() * A.translation();
  return A_inv * B.matrix();
}

Eigen::Matrix4d relative(const Eigen::Matrix4d& A, const Eigen::Matrix4d& B) {
  SE3 a;
  a.matrix() = A;
  SE3 b;
  b.matrix() = B;
  return relative(a, b);
}

}  // namespace

std::optional<Stats> computeStats(const std::vector<double>& errors) {
  if (errors.empty()) return std::nullopt;
  Stats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  for (double e : errors) {
    sum += e;
    s.sse += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(s.sse / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const std::size_t m = sorted.size() / 2;
  s.median = sorted.size() % 2 ? sorted[m] : 0.5 * (sorted[m - 1] + sorted[m]);
  return s;
}

Associated associateByTime(const Trajectory& ref, const Trajectory& est, Timestamp max_diff_ns) {
  const bool est_longer = est.size() > ref.size();
  const Trajectory& shorter = est_longer ? ref : est;
  const Trajectory& longer = est_longer ? est : ref;
  Associated out;
  if (longer.empty()) return out;
  // Nearest stamp by binary search (both are sorted), ties to the earlier one as argmin does.
  for (const auto& pose : shorter) {
    const auto it = std::lower_bound(longer.begin(), longer.end(), pose.t_ns,
                                     [](const StampedPose& p, Timestamp t) { return p.t_ns < t; });
    std::size_t best = static_cast<std::size_t>(it - longer.begin());
    if (best == longer.size()) {
      best = longer.size() - 1;
    } else if (best > 0) {
      // lower_bound gives the first >= t; among equal stamps argmin takes the first as well.
      const Timestamp d_hi = longer[best].t_ns - pose.t_ns;
      const Timestamp d_lo = pose.t_ns - longer[best - 1].t_ns;
      if (d_lo <= d_hi) {
        best = best - 1;
        while (best > 0 && longer[best - 1].t_ns == longer[best].t_ns) --best;
      }
    }
    if (std::llabs(longer[best].t_ns - pose.t_ns) > max_diff_ns) continue;
    const StampedPose& matched = longer[best];
    out.ref.push_back(est_longer ? pose : matched);
    out.est.push_back(est_longer ? matched : pose);
  }
  return out;
}

Associated associateByIndex(const Trajectory& ref, const Trajectory& est) {
  const std::size_t n = std::min(ref.size(), est.size());
  Associated out;
  out.ref.assign(ref.begin(), ref.begin() + static_cast<std::ptrdiff_t>(n));
  out.est.assign(est.begin(), est.begin() + static_cast<std::ptrdiff_t>(n));
  return out;
}

std::optional<AteResult> computeAte(const Associated& pairs, AlignMode mode) {
  if (pairs.ref.empty() || pairs.ref.size() != pairs.est.size()) return std::nullopt;
  const auto alignment = alignTrajectories(pairs.ref, pairs.est, mode);
  if (!alignment) return std::nullopt;
  AteResult out;
  out.mode = mode;
  out.alignment = *alignment;
  out.errors_m.reserve(pairs.size());
  Vec3 body_sq = Vec3::Zero();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Vec3 p_est = alignment->apply(Vec3(pairs.est[i].T_W_B.translation()));
    const Vec3 e_W = p_est - pairs.ref[i].T_W_B.translation();
    out.errors_m.push_back(e_W.norm());
    body_sq += (pairs.ref[i].T_W_B.linear().transpose() * e_W).cwiseAbs2();
  }
  out.trans_m = *computeStats(out.errors_m);
  out.body_rmse_m = (body_sq / static_cast<double>(pairs.size())).cwiseSqrt();
  return out;
}

std::optional<DeltaUnit> parseDeltaUnit(const std::string& name) {
  if (name == "f") return DeltaUnit::kFrames;
  if (name == "m") return DeltaUnit::kMeters;
  if (name == "s") return DeltaUnit::kSeconds;
  return std::nullopt;
}

std::string deltaUnitName(DeltaUnit unit) {
  switch (unit) {
    case DeltaUnit::kFrames:
      return "f";
    case DeltaUnit::kMeters:
      return "m";
    case DeltaUnit::kSeconds:
      return "s";
  }
  return "?";
}

std::vector<std::pair<std::size_t, std::size_t>> rpePairs(const Trajectory& trajectory,
                                                          double delta, DeltaUnit unit) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  if (!(delta > 0.0) || !std::isfinite(delta) || trajectory.empty()) return pairs;
  std::vector<std::size_t> ids;
  if (unit == DeltaUnit::kFrames) {
    const auto step = static_cast<std::size_t>(std::llround(delta));
    if (step == 0) return pairs;
    for (std::size_t i = 0; i < trajectory.size(); i += step) ids.push_back(i);
  } else {
    double accumulated = 0.0;
    for (std::size_t i = 1; i < trajectory.size(); ++i) {
      accumulated +=
          unit == DeltaUnit::kMeters
              ? (trajectory[i].T_W_B.translation() - trajectory[i - 1].T_W_B.translation()).norm()
              : toSeconds(trajectory[i].t_ns - trajectory[i - 1].t_ns);
      if (accumulated >= delta) {
        ids.push_back(i);
        accumulated = 0.0;
      }
    }
  }
  for (std::size_t k = 1; k < ids.size(); ++k) pairs.emplace_back(ids[k - 1], ids[k]);
  return pairs;
}

std::optional<RpeResult> computeRpe(const Associated& pairs, const RpeOptions& options) {
  if (pairs.ref.empty() || pairs.ref.size() != pairs.est.size()) return std::nullopt;
  RpeResult out;
  out.id_pairs =
      rpePairs(options.pairs_from_reference ? pairs.ref : pairs.est, options.delta, options.unit);
  if (out.id_pairs.empty()) return std::nullopt;
  for (const auto& [i, j] : out.id_pairs) {
    const Eigen::Matrix4d Q_rel = relative(pairs.ref[i].T_W_B, pairs.ref[j].T_W_B);
    const Eigen::Matrix4d P_rel = relative(pairs.est[i].T_W_B, pairs.est[j].T_W_B);
    const Eigen::Matrix4d E = relative(Q_rel, P_rel);
    out.trans_m.push_back(E.topRightCorner<3, 1>().norm());
    out.rot_deg.push_back(rotationAngleRad(E.topLeftCorner<3, 3>()) * kRadToDeg);
  }
  out.trans = *computeStats(out.trans_m);
  out.rot = *computeStats(out.rot_deg);
  return out;
}

double pathLength(const Trajectory& trajectory) {
  double length = 0.0;
  for (std::size_t i = 1; i < trajectory.size(); ++i)
    length += (trajectory[i].T_W_B.translation() - trajectory[i - 1].T_W_B.translation()).norm();
  return length;
}

namespace {

// Reference path length up to each pose.
std::vector<double> distances(const Trajectory& ref) {
  std::vector<double> dist(ref.size(), 0.0);
  for (std::size_t i = 1; i < ref.size(); ++i)
    dist[i] = dist[i - 1] + (ref[i].T_W_B.translation() - ref[i - 1].T_W_B.translation()).norm();
  return dist;
}

// The KITTI devkit's segments: every 10th first frame, to the first frame whose path length
// from it exceeds L. fn(length index, translation error [m], rotation error [deg]).
template <typename Fn>
void forEachSegment(const Associated& pairs, const std::vector<double>& dist,
                    const std::vector<double>& lengths, Fn&& fn) {
  constexpr std::size_t kStepFrames = 10;  // the devkit's step_size
  const std::size_t n = pairs.size();
  for (std::size_t first = 0; first < n; first += kStepFrames) {
    for (std::size_t k = 0; k < lengths.size(); ++k) {
      const double L = lengths[k];
      const auto it = std::upper_bound(dist.begin() + static_cast<std::ptrdiff_t>(first),
                                       dist.end(), dist[first] + L);
      if (it == dist.end()) continue;
      const auto last = static_cast<std::size_t>(it - dist.begin());
      const Eigen::Matrix4d Q_rel = relative(pairs.ref[first].T_W_B, pairs.ref[last].T_W_B);
      const Eigen::Matrix4d P_rel = relative(pairs.est[first].T_W_B, pairs.est[last].T_W_B);
      const Eigen::Matrix4d E = relative(P_rel, Q_rel);
      fn(k, E.topRightCorner<3, 1>().norm(),
         rotationAngleRad(E.topLeftCorner<3, 3>()) * kRadToDeg);
    }
  }
}

}  // namespace

std::optional<DriftResult> kittiDrift(const Associated& pairs) {
  const std::size_t n = pairs.size();
  if (n < 2 || pairs.est.size() != n) return std::nullopt;
  const std::vector<double> dist = distances(pairs.ref);
  DriftResult out;
  std::vector<double> lengths = {100, 200, 300, 400, 500, 600, 700, 800};
  if (dist.back() < 800.0) {
    out.full_lengths = false;
    for (double& L : lengths) L = L / 1000.0 * dist.back();
  }
  if (!(lengths.front() > 0.0)) return std::nullopt;
  double sum_t = 0.0, sum_r = 0.0;
  forEachSegment(pairs, dist, lengths, [&](std::size_t k, double t_m, double r_deg) {
    sum_t += t_m / lengths[k];
    sum_r += r_deg / lengths[k];
    ++out.segments;
  });
  if (out.segments == 0) return std::nullopt;
  out.trans_pct = 100.0 * sum_t / static_cast<double>(out.segments);
  out.rot_deg_per_m = sum_r / static_cast<double>(out.segments);
  return out;
}

std::vector<SegmentError> segmentErrors(const Associated& pairs,
                                        const std::vector<double>& lengths_m) {
  std::vector<SegmentError> out;
  const std::size_t n = pairs.size();
  if (n < 2 || pairs.est.size() != n) return out;
  std::vector<double> lengths;
  for (double L : lengths_m)
    if (L > 0.0 && std::isfinite(L)) lengths.push_back(L);
  std::vector<SegmentError> acc(lengths.size());
  forEachSegment(pairs, distances(pairs.ref), lengths,
                 [&](std::size_t k, double t_m, double r_deg) {
                   acc[k].trans_pct += t_m;
                   acc[k].rot_deg_per_100m += r_deg;
                   ++acc[k].count;
                 });
  for (std::size_t k = 0; k < lengths.size(); ++k) {
    if (acc[k].count == 0) continue;
    const double per = 100.0 / (lengths[k] * static_cast<double>(acc[k].count));
    out.push_back({lengths[k], acc[k].count, acc[k].trans_pct * per,
                   acc[k].rot_deg_per_100m * per});
  }
  return out;
}

std::optional<DriftCurve> driftAlongPath(const Associated& pairs, double scale_window_m,
                                         const Vec3& up_W) {
  const std::size_t n = pairs.size();
  if (n < 2 || pairs.est.size() != n || !(scale_window_m > 0.0)) return std::nullopt;
  const auto origin = alignFirstPose(pairs.ref, pairs.est);
  if (!origin) return std::nullopt;
  const std::vector<double> dist = distances(pairs.ref);
  DriftCurve out;
  // Scale: steps between poses 1 m apart along the reference, summed over the trailing window.
  std::vector<std::size_t> marks = {0};
  std::vector<double> step_ref, step_est;  // step k ends at marks[k + 1]
  constexpr double kStepM = 1.0;
  Associated last;  // the one pose pair finalYawErrorDeg looks at
  last.ref.resize(1);
  last.est.resize(1);
  for (std::size_t i = 0; i < n; ++i) {
    if (dist[i] >= dist[marks.back()] + kStepM) {
      const std::size_t a = marks.back();
      step_ref.push_back(
          (pairs.ref[i].T_W_B.translation() - pairs.ref[a].T_W_B.translation()).norm());
      step_est.push_back(
          (pairs.est[i].T_W_B.translation() - pairs.est[a].T_W_B.translation()).norm());
      marks.push_back(i);
    }
    out.distance_m.push_back(dist[i]);
    const Vec3 p = origin->apply(Vec3(pairs.est[i].T_W_B.translation()));
    out.pos_err_m.push_back((p - pairs.ref[i].T_W_B.translation()).norm());
    last.ref[0] = pairs.ref[i];
    last.est[0] = pairs.est[i];
    out.yaw_err_deg.push_back(
        finalYawErrorDeg(last, *origin, up_W).value_or(std::numeric_limits<double>::quiet_NaN()));
    double scale = std::numeric_limits<double>::quiet_NaN();
    if (dist[marks.back()] >= scale_window_m) {
      double sum_ref = 0.0, sum_est = 0.0;
      for (std::size_t k = step_ref.size(); k-- > 0;) {
        if (dist[marks.back()] - dist[marks[k]] > scale_window_m) break;
        sum_ref += step_ref[k];
        sum_est += step_est[k];
      }
      if (sum_ref > 0.0) scale = 100.0 * (sum_est / sum_ref - 1.0);
    }
    out.scale_err_pct.push_back(scale);
  }
  return out;
}

std::optional<double> finalYawErrorDeg(const Associated& pairs, const Similarity& alignment,
                                       const Vec3& up_W) {
  if (pairs.ref.empty() || pairs.ref.size() != pairs.est.size() || !(up_W.norm() > 0.0))
    return std::nullopt;
  const Mat3 R_est = alignment.R * pairs.est.back().T_W_B.linear();
  const Mat3 R_err = R_est * pairs.ref.back().T_W_B.linear().transpose();
  // Twist of the error rotation about up (swing-twist decomposition of its quaternion).
  Eigen::JacobiSVD<Mat3> svd(R_err, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0.0) return std::nullopt;
  const Quat q(R);
  const double twist = 2.0 * std::atan2(q.vec().dot(up_W.normalized()), q.w());
  double deg = twist * kRadToDeg;
  while (deg > 180.0) deg -= 360.0;
  while (deg <= -180.0) deg += 360.0;
  return deg;
}

std::optional<double> scaleErrorPct(const Associated& pairs) {
  const auto S = alignTrajectories(pairs.ref, pairs.est, AlignMode::kSim3);
  if (!S) return std::nullopt;
  return 100.0 * (1.0 / S->scale - 1.0);
}

}  // namespace ovo::eval
