#include "calib/rig_calibration.hpp"

#include <ceres/autodiff_cost_function.h>
#include <ceres/covariance.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/rotation.h>
#include <ceres/solver.h>
#include <ceres/sphere_manifold.h>
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "calib/projection.hpp"
#include "common/error.hpp"
#include "common/so3.hpp"
#include "common/stats.hpp"

namespace ovo::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kMadToSigma = 1.4826;  // a normal sample's median absolute deviation to its sigma

// Gyro samples on a double time axis (seconds from the first sample).
struct GyroSeries {
  Timestamp t0_ns = 0;
  std::vector<double> t_s;
  std::vector<Vec3> w;
  double seconds(Timestamp t_ns) const { return 1e-9 * static_cast<double>(t_ns - t0_ns); }
};

GyroSeries gyroSeries(const std::vector<ImuSample>& gyro) {
  GyroSeries g;
  if (gyro.empty()) return g;
  g.t0_ns = gyro.front().t_ns;
  for (const ImuSample& s : gyro) {
    g.t_s.push_back(g.seconds(s.t_ns));
    g.w.push_back(s.gyro_radps);
  }
  return g;
}

// Body rotation dR_B(ta -> tb) = prod Exp((w - b) dt) with the rate linearly interpolated at the
// ends and averaged over each step (as factors/gyro_preintegration), as a quaternion (w, x, y, z)
// in T so that the time offset and the bias carry derivatives. False outside the samples.
template <typename T>
bool gyroDelta(const GyroSeries& g, const T& ta, const T& tb, const T* bias, T* q) {
  const double a = scalarPart(ta), b = scalarPart(tb);
  if (g.t_s.size() < 2 || !(a >= g.t_s.front() && b <= g.t_s.back() && b > a)) return false;
  const auto upper = [&](double t) {
    return static_cast<std::size_t>(std::upper_bound(g.t_s.begin(), g.t_s.end(), t) -
                                    g.t_s.begin());
  };
  const auto rateAt = [&](const T& t, std::size_t hi, T* out) {
    const std::size_t i1 = std::min(std::max<std::size_t>(hi, 1), g.t_s.size() - 1), i0 = i1 - 1;
    const T f = (t - g.t_s[i0]) / (g.t_s[i1] - g.t_s[i0]);
    for (int k = 0; k < 3; ++k) out[k] = T(g.w[i0](k)) + f * (g.w[i1](k) - g.w[i0](k));
  };
  const std::size_t first = upper(a), last = upper(b);  // samples strictly inside: first..last-1
  q[0] = T(1.0);
  q[1] = q[2] = q[3] = T(0.0);
  T t_prev = ta, w_prev[3];
  rateAt(ta, first, w_prev);
  for (std::size_t i = first; i <= last; ++i) {
    T t_next, w_next[3];
    if (i < last) {
      t_next = T(g.t_s[i]);
      for (int k = 0; k < 3; ++k) w_next[k] = T(g.w[i](k));
    } else {
      t_next = tb;
      rateAt(tb, last, w_next);
    }
    const T dt = t_next - t_prev;
    T angle_axis[3], dq[4], out[4];
    for (int k = 0; k < 3; ++k) angle_axis[k] = (T(0.5) * (w_prev[k] + w_next[k]) - bias[k]) * dt;
    ceres::AngleAxisToQuaternion(angle_axis, dq);
    ceres::QuaternionProduct(q, dq, out);
    std::copy(out, out + 4, q);
    t_prev = t_next;
    std::copy(w_next, w_next + 3, w_prev);
  }
  return true;
}

Mat3 gyroDeltaR(const GyroSeries& g, double ta, double tb, const Vec3& bias, bool* ok) {
  double q[4];
  *ok = gyroDelta(g, ta, tb, bias.data(), q);
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
}

// Pearson correlation of two series.
double correlation(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  if (x.size() < 3) return 0.0;
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n;
  const double my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  return sxx > 0.0 && syy > 0.0 ? sxy / std::sqrt(sxx * syy) : 0.0;
}

// The rotation R minimising sum |b_i - R a_i|^2 (Kabsch).
Mat3 kabsch(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  Mat3 H = Mat3::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) H += b[i] * a[i].transpose();
  Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

struct Pair {
  double t0_s, t1_s;  // image stamps on the gyro's time axis (before the offset)
  Vec3 r_C;           // log of the camera's rotation from frame 0 to frame 1, in C0
  Mat3 cov_C;         // its covariance [rad^2] (zero: unknown)
  bool low_parallax;  // scaled as a group of its own
};

// W Log(dR_B(t0 - t_d, t1 - t_d; b)^T  R_B_C dR_C  R_B_C^T) with R_B_C = R0 Exp(delta) and W
// the pair's square-root information (W^T W = the inverse covariance of the error, in B).
struct RotationResidual {
  const GyroSeries* gyro;
  Pair pair;
  Mat3 R0;
  Mat3 W;
  template <typename T>
  bool operator()(const T* delta, const T* t_d, const T* bias, T* residual) const {
    T q_B[4];
    if (!gyroDelta(*gyro, T(pair.t0_s) - t_d[0], T(pair.t1_s) - t_d[0], bias, q_B)) return false;
    // R_B_C = R0 Exp(delta); the camera rotation mapped into B: R_B_C Exp(r_C) R_B_C^T =
    // Exp(R_B_C r_C).
    T R_delta[9];
    ceres::AngleAxisToRotationMatrix(delta, R_delta);  // column-major
    T rc_delta[3];
    for (int r = 0; r < 3; ++r)
      rc_delta[r] =
          R_delta[r] * pair.r_C(0) + R_delta[3 + r] * pair.r_C(1) + R_delta[6 + r] * pair.r_C(2);
    T r_B_cam[3];
    for (int r = 0; r < 3; ++r)
      r_B_cam[r] = R0(r, 0) * rc_delta[0] + R0(r, 1) * rc_delta[1] + R0(r, 2) * rc_delta[2];
    T q_cam[4], q_B_conj[4] = {q_B[0], -q_B[1], -q_B[2], -q_B[3]}, q_err[4];
    ceres::AngleAxisToQuaternion(r_B_cam, q_cam);
    ceres::QuaternionProduct(q_B_conj, q_cam, q_err);
    if (q_err[0] < T(0.0))
      for (T& v : q_err) v = -v;
    T err[3];
    ceres::QuaternionToAngleAxis(q_err, err);
    for (int r = 0; r < 3; ++r)
      residual[r] = W(r, 0) * err[0] + W(r, 1) * err[1] + W(r, 2) * err[2];
    return true;
  }
};

}  // namespace

RigCalibration calibrateRigFromRotations(const std::vector<CameraRotation>& rotations,
                                         const std::vector<ImuSample>& gyro_samples,
                                         const RigCalibrationOptions& options,
                                         const Mat3& R_B_C_prior) {
  const GyroSeries g = gyroSeries(gyro_samples);
  if (g.t_s.size() < 10) fail("rig calibration: fewer than 10 gyro samples");
  std::vector<Pair> pairs;
  std::vector<double> rates;
  for (const CameraRotation& r : rotations) {
    const double t0 = g.seconds(r.t0_ns), t1 = g.seconds(r.t1_ns);
    if (!(t1 > t0)) continue;
    // Both shifted ends must stay inside the gyro's span for every offset searched.
    if (t0 - options.max_offset_s < g.t_s.front() || t1 + options.max_offset_s > g.t_s.back())
      continue;
    const Vec3 r_C = so3::log(r.R_C1_C0.transpose());  // the camera's rotation, C0 -> C1
    pairs.push_back({t0, t1, r_C, r.covariance, r.low_parallax});
    rates.push_back(r_C.norm() / (t1 - t0));
  }
  if (static_cast<int>(pairs.size()) < options.min_pairs)
    fail(
        "rig calibration: {} usable frame pairs inside the gyro's time span, at least {} are "
        "needed",
        pairs.size(), options.min_pairs);
  RigCalibration out;
  out.median_rate_dps = upperMedian(rates) / kDeg;

  // 1. Time offset: correlation of the angular speeds over a grid of offsets.
  const Vec3 zero = Vec3::Zero();
  double best_corr = -2.0, best_td = 0.0;
  std::vector<double> corr_values, td_values;
  const int steps = static_cast<int>(std::round(options.max_offset_s / options.search_step_s));
  for (int s = -steps; s <= steps; ++s) {
    const double td = s * options.search_step_s;
    std::vector<double> gyro_rates;
    gyro_rates.reserve(pairs.size());
    bool ok = true;
    for (const Pair& p : pairs) {
      const Mat3 dR = gyroDeltaR(g, p.t0_s - td, p.t1_s - td, zero, &ok);
      if (!ok) break;
      gyro_rates.push_back(so3::log(dR).norm() / (p.t1_s - p.t0_s));
    }
    if (!ok) continue;
    const double c = correlation(rates, gyro_rates);
    td_values.push_back(td);
    corr_values.push_back(c);
    if (c > best_corr) {
      best_corr = c;
      best_td = td;
    }
  }
  const std::size_t best_index =
      std::max_element(corr_values.begin(), corr_values.end()) - corr_values.begin();
  if (best_index == 0 || best_index + 1 >= corr_values.size())
    fail(
        "rig calibration: the angular speeds correlate best at the edge of the searched offsets "
        "(+-{} s); widen --max-offset or check the stamps",
        options.max_offset_s);
  if (best_corr < 0.5)
    fail(
        "rig calibration: the camera's and the gyro's angular speeds do not correlate (best "
        "{:.2f}); the sequence needs rotation that changes over time",
        best_corr);
  {  // parabola through the peak and its neighbours
    const double c0 = corr_values[best_index - 1], c1 = corr_values[best_index],
                 c2 = corr_values[best_index + 1];
    const double denom = c0 - 2.0 * c1 + c2;
    if (denom < 0.0) best_td += 0.5 * (c0 - c2) / denom * options.search_step_s;
  }
  out.coarse_offset_s = best_td;
  out.correlation = best_corr;

  // 2. R_B_C in closed form (Kabsch on the rotation vectors), alternating with the gyro bias.
  std::vector<Vec3> r_B(pairs.size());
  std::vector<double> dts(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    bool ok = true;
    r_B[i] = so3::log(gyroDeltaR(g, pairs[i].t0_s - best_td, pairs[i].t1_s - best_td, zero, &ok));
    dts[i] = pairs[i].t1_s - pairs[i].t0_s;
  }
  std::vector<Vec3> a, b;
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (pairs[i].r_C.norm() > options.min_rotation_deg * kDeg) idx.push_back(i);
  if (static_cast<int>(idx.size()) < options.min_pairs)
    fail("rig calibration: {} frame pairs rotate by more than {} deg, at least {} are needed",
         idx.size(), options.min_rotation_deg, options.min_pairs);
  // Rotation axes must span more than one direction.
  {
    Mat3 S = Mat3::Zero();
    for (std::size_t i : idx)
      S += pairs[i].r_C.normalized() * pairs[i].r_C.normalized().transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(S / idx.size());
    const double spread = std::asin(std::sqrt(std::max(0.0, eig.eigenvalues()(1)))) / kDeg;
    if (spread < options.min_axis_spread_deg)
      fail(
          "rig calibration: the camera rotates about one axis only (axes spread {:.1f} deg, at "
          "least {} deg needed); R_B_C needs rotation about two axes (roll or pitch as well as "
          "yaw)",
          spread, options.min_axis_spread_deg);
  }
  Vec3 bias = Vec3::Zero();
  Mat3 R = Mat3::Identity();
  for (int iter = 0; iter < 3; ++iter) {
    a.clear();
    b.clear();
    for (std::size_t i : idx) {
      a.push_back(pairs[i].r_C);
      b.push_back(r_B[i] - bias * dts[i]);  // small rotations: log dR(b) ~ log dR(0) - b dt
    }
    R = kabsch(a, b);
    Vec3 sum = Vec3::Zero();
    double sum_dt2 = 0.0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      sum += (r_B[i] - R * pairs[i].r_C) * dts[i];
      sum_dt2 += dts[i] * dts[i];
    }
    bias = sum / sum_dt2;
  }
  out.R_B_C_closed_form = R;

  // 3. Joint refinement. Each pair's error is weighted by its covariance in B: the camera
  // rotation's (mapped by R_B_C) plus the gyro's white noise integrated over the pair. Pairs
  // whose rotation trades with their translation (a short baseline) have a wide covariance and
  // count less. A pair without one takes the widest of the others; when fewer than half have
  // one, every pair counts alike. The covariances' shapes are kept and their sizes are not
  // trusted: a pair's matches share their errors in part (a region's flow), which the spread of
  // its residuals does not show, and more so with low parallax. So the weights of each group
  // (pairs with and without parallax) are scaled by the robust spread of that group's weighted
  // residuals, which also puts them in the units of the Huber loss.
  std::size_t with_covariance = 0;
  for (const Pair& p : pairs) with_covariance += p.cov_C.isZero() ? 0 : 1;
  const bool weighted = 2 * with_covariance >= pairs.size();
  std::vector<Mat3> weights(pairs.size(), Mat3::Identity());
  if (weighted) {
    std::vector<bool> have(pairs.size(), false);
    double widest = -1.0;
    Mat3 widest_weight = Mat3::Identity();
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (pairs[i].cov_C.isZero()) continue;
      const double gyro_var = options.gyro_noise_density * options.gyro_noise_density * dts[i];
      const Mat3 S = R * pairs[i].cov_C * R.transpose() + gyro_var * Mat3::Identity();
      const Eigen::LLT<Mat3> llt(S.inverse());
      if (llt.info() != Eigen::Success) continue;
      weights[i] = llt.matrixU();
      have[i] = true;
      if (S.trace() > widest) {
        widest = S.trace();
        widest_weight = weights[i];
      }
    }
    for (std::size_t i = 0; i < pairs.size(); ++i)
      if (!have[i]) weights[i] = widest_weight;
  }
  std::vector<double> pre(pairs.size()), group_pre[2];
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    bool ok = true;
    const Mat3 dR = gyroDeltaR(g, pairs[i].t0_s - best_td, pairs[i].t1_s - best_td, bias, &ok);
    pre[i] = (weights[i] * so3::log(dR.transpose() * so3::exp(R * pairs[i].r_C))).norm();
    group_pre[pairs[i].low_parallax ? 1 : 0].push_back(pre[i]);
  }
  const double floor = weighted ? 1e-3 : 1e-5;
  const double overall = std::max(floor, kMadToSigma * upperMedian(pre));
  double group_scale[2];
  for (int k = 0; k < 2; ++k)  // a group too small for a spread of its own takes the overall one
    group_scale[k] = group_pre[k].size() >= 10
                         ? std::max(floor, kMadToSigma * upperMedian(group_pre[k]))
                         : overall;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    weights[i] /= group_scale[pairs[i].low_parallax ? 1 : 0];
  double delta[3] = {0, 0, 0}, t_d = best_td, b_g[3] = {bias.x(), bias.y(), bias.z()};
  ceres::Problem problem;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RotationResidual, 3, 3, 1, 3>(
                                 new RotationResidual{&g, pairs[i], R, weights[i]}),
                             new ceres::HuberLoss(2.0), delta, &t_d, b_g);
  problem.SetParameterLowerBound(&t_d, 0, -options.max_offset_s);
  problem.SetParameterUpperBound(&t_d, 0, options.max_offset_s);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 100;
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  out.R_B_C = R * so3::exp(Vec3(delta[0], delta[1], delta[2]));
  out.time_offset_s = t_d;
  out.gyro_bias_radps = Vec3(b_g[0], b_g[1], b_g[2]);
  double sum2 = 0.0;
  int n = 0;
  for (const Pair& p : pairs) {
    bool ok = true;
    const Mat3 dR = gyroDeltaR(g, p.t0_s - t_d, p.t1_s - t_d, out.gyro_bias_radps, &ok);
    if (!ok) continue;
    const double e = so3::log(dR.transpose() * so3::exp(out.R_B_C * p.r_C)).norm();
    sum2 += e * e;
    ++n;
  }
  out.residual_rms_deg = n ? std::sqrt(sum2 / n) / kDeg : 0.0;
  out.pairs_used = static_cast<int>(pairs.size());
  out.rotation_change_deg = so3::angle(R_B_C_prior.transpose() * out.R_B_C) / kDeg;
  if (summary.termination_type == ceres::NO_CONVERGENCE)
    out.notes.push_back("the joint refinement stopped at its iteration limit");
  return out;
}

namespace {

double angleBetween(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// The rotation alone that maps the previous bearings onto the current ones (Kabsch, matches
// beyond three times the median residual dropped twice), and its median residual angle.
Mat3 rotationOnly(const frontend::FrameMatches& m, const std::vector<std::uint8_t>& inliers,
                  double* median_residual) {
  std::vector<std::size_t> use;
  for (std::size_t i = 0; i < m.size(); ++i)
    if (inliers.empty() || inliers[i]) use.push_back(i);
  Mat3 R = Mat3::Identity();
  for (int round = 0; round < 3; ++round) {
    std::vector<Vec3> a, b;
    for (std::size_t i : use) {
      a.push_back(m.bearings_prev[i]);
      b.push_back(m.bearings_cur[i]);
    }
    if (a.size() < 3) break;
    R = kabsch(a, b);
    std::vector<double> res;
    for (std::size_t i : use)
      res.push_back(angleBetween(m.bearings_cur[i], R * m.bearings_prev[i]));
    *median_residual = upperMedian(res);
    std::vector<std::size_t> keep;
    for (std::size_t k = 0; k < use.size(); ++k)
      if (res[k] <= 3.0 * *median_residual) keep.push_back(use[k]);
    use.swap(keep);
  }
  return R;
}

// Sine of the angle of the current bearing from the epipolar plane of (R = R0 Exp(delta), t).
struct EpipolarResidual {
  Vec3 prev, cur;
  Mat3 R0;
  template <typename T>
  bool operator()(const T* delta, const T* t, T* residual) const {
    const T p[3] = {T(prev.x()), T(prev.y()), T(prev.z())};
    T rp[3], Rp[3];
    ceres::AngleAxisRotatePoint(delta, p, rp);
    for (int r = 0; r < 3; ++r) Rp[r] = R0(r, 0) * rp[0] + R0(r, 1) * rp[1] + R0(r, 2) * rp[2];
    T n[3];
    ceres::CrossProduct(t, Rp, n);
    const T norm = ceres::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + T(1e-18));
    residual[0] = (cur.x() * n[0] + cur.y() * n[1] + cur.z() * n[2]) / norm;
    return true;
  }
};

// (R, t) refined on the matches by the angular epipolar error (Huber at twice the RANSAC
// threshold), from the frontend's estimate: the 8-point solution in RANSAC is noisy when the
// baseline is short (a turn on the spot with the camera ahead of the turning axis), and its
// rotation error trades with the translation. `covariance` (when given) receives the covariance
// of the rotation's correction in C0 [rad^2], with t free: the residuals' robust spread times
// (J^T J)^-1 of the rotation block; zero when it cannot be computed.
Mat3 refineRelativePose(const frontend::FrameMatches& m, const std::vector<std::uint8_t>& inliers,
                        const Mat3& R0, const std::vector<Vec3>& t_starts, double threshold_rad,
                        Mat3* covariance) {
  if (covariance) covariance->setZero();
  std::vector<std::size_t> use;
  for (std::size_t i = 0; i < m.size(); ++i)
    if (inliers.empty() || inliers[i]) use.push_back(i);
  if (use.size() < 8) return R0;
  // At most 200 matches, spread over the list (the frontend buckets them over the image).
  constexpr std::size_t kMaxMatches = 200;
  if (use.size() > kMaxMatches) {
    std::vector<std::size_t> sub;
    for (std::size_t k = 0; k < kMaxMatches; ++k) sub.push_back(use[k * use.size() / kMaxMatches]);
    use.swap(sub);
  }
  const auto build = [&](ceres::Problem* problem, double* delta, Vec3* t) {
    for (std::size_t i : use) {
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<EpipolarResidual, 1, 3, 3>(
              new EpipolarResidual{m.bearings_prev[i], m.bearings_cur[i], R0}),
          new ceres::HuberLoss(2.0 * threshold_rad), delta, t->data());
    }
    problem->SetManifold(t->data(), new ceres::SphereManifold<3>);
  };
  double best_cost = std::numeric_limits<double>::infinity();
  double best_delta[3] = {0, 0, 0};
  Vec3 best_t = Vec3::UnitZ();
  for (const Vec3& t_start : t_starts) {
    double delta[3] = {0, 0, 0};
    Vec3 t = t_start.normalized();
    ceres::Problem problem;
    build(&problem, delta, &t);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (summary.final_cost < best_cost) {
      best_cost = summary.final_cost;
      std::copy(delta, delta + 3, best_delta);
      best_t = t;
    }
  }
  if (!std::isfinite(best_cost)) return R0;
  if (covariance) {
    ceres::Problem problem;
    build(&problem, best_delta, &best_t);
    ceres::Problem::EvaluateOptions eval;
    eval.apply_loss_function = false;
    std::vector<double> residuals;
    problem.Evaluate(eval, nullptr, &residuals, nullptr, nullptr);
    for (double& r : residuals) r = std::abs(r);
    const double spread = kMadToSigma * upperMedian(residuals);
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    ceres::Covariance cov(co);
    const std::vector<std::pair<const double*, const double*>> blocks = {{best_delta, best_delta}};
    Mat3 c;  // row-major from Ceres; symmetric
    if (spread > 0.0 && cov.Compute(blocks, &problem) &&
        cov.GetCovarianceBlock(best_delta, best_delta, c.data()) && c.allFinite())
      *covariance = spread * spread * c;
  }
  return R0 * so3::exp(Vec3(best_delta[0], best_delta[1], best_delta[2]));
}

}  // namespace

std::vector<CameraRotation> frontendRotations(const RigInput& input) {
  if (!input.camera) fail("rig calibration: no camera model");
  frontend::FrontendOptions options = input.frontend;
  options.use_rotation_prior = false;
  frontend::Frontend fe(*input.camera, options);
  std::vector<CameraRotation> out;
  Timestamp prev = 0;
  for (std::size_t k = 0; k < input.frame_count; ++k) {
    const Timestamp t = input.frame_stamp(k);
    const frontend::FrontendResult res = fe.process(t, input.frame_image(k));
    if (k > 0 && res.relative_pose) {
      using Status = frontend::RelativePoseResult::Status;
      const auto& rp = *res.relative_pose;
      if (rp.status == Status::kOk || rp.status == Status::kLowParallax) {
        // (R, t) refined on the matches; with low parallax (the RANSAC's t is 0) from the
        // rotation-only fit and six directions of t.
        const bool has_t = rp.status == Status::kOk && rp.t_cur_prev.norm() > 0.5;
        double rot_median = 0.0;
        const Mat3 R_start =
            has_t ? rp.R_cur_prev : rotationOnly(res.matches, rp.inliers, &rot_median);
        std::vector<Vec3> starts;
        if (has_t)
          starts.push_back(rp.t_cur_prev);
        else
          for (int a = 0; a < 3; ++a)
            for (double sgn : {1.0, -1.0}) starts.push_back(sgn * Vec3::Unit(a));
        Mat3 covariance;
        const Mat3 R_refined =
            refineRelativePose(res.matches, rp.inliers, R_start, starts,
                               options.relative_pose.inlier_threshold_rad, &covariance);
        out.push_back({prev, t, R_refined, rp.num_inliers, covariance, !has_t});
      }
    }
    prev = t;
  }
  return out;
}

RigCalibration calibrateRig(const RigInput& input, const RigCalibrationOptions& options) {
  return calibrateRigFromRotations(frontendRotations(input), input.gyro, options,
                                   input.R_B_C_prior);
}

}  // namespace ovo::calib
