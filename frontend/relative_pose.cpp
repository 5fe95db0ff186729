#include "frontend/relative_pose.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "frontend/essential.hpp"
#include "frontend/ransac.hpp"

namespace ovo::frontend {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Chord |R b_prev - b_cur| between unit vectors: a monotone stand-in for their angle
// 2 asin(chord / 2), cheap enough for the gating loops.
double rotatedChord(const Mat3& R, const Vec3& b_prev, const Vec3& b_cur) {
  return (R * b_prev - b_cur).norm();
}
double chordToAngle(double chord) { return 2.0 * std::asin(std::min(1.0, 0.5 * chord)); }
double angleToChord(double angle_rad) { return 2.0 * std::sin(0.5 * std::min(angle_rad, M_PI)); }

double medianRotatedAngle(const Mat3& R, const std::vector<Vec3>& b_prev,
                          const std::vector<Vec3>& b_cur, const std::vector<std::uint8_t>& flags) {
  std::vector<double> chords;
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) chords.push_back(rotatedChord(R, b_prev[i], b_cur[i]));
  if (chords.empty()) return 0.0;
  auto mid = chords.begin() + chords.size() / 2;
  std::nth_element(chords.begin(), mid, chords.end());
  return chordToAngle(*mid);
}

int countFlags(const std::vector<std::uint8_t>& flags) {
  return static_cast<int>(std::count(flags.begin(), flags.end(), std::uint8_t{1}));
}

}  // namespace

RelativePoseOptions readRelativePoseOptions(const Config& cfg) {
  RelativePoseOptions o;
  o.backend = cfg.getChoice("ransac.backend", o.backend, {"serial", "threads", "opencl", "auto"});
  o.max_iterations = cfg.getIntInRange("ransac.max_iterations", o.max_iterations, 1, 1000000);
  o.adaptive = cfg.get<bool>("ransac.adaptive", o.adaptive);
  o.confidence = cfg.getInRange("ransac.confidence", o.confidence, 0.5, 0.999999999);
  o.inlier_threshold_rad =
      cfg.getInRange("ransac.inlier_threshold_rad", o.inlier_threshold_rad, 1e-7, 0.5);
  const auto seed = cfg.get<std::int64_t>("ransac.seed", static_cast<std::int64_t>(o.seed));
  o.seed = static_cast<std::uint64_t>(seed);
  o.min_inliers = cfg.getIntInRange("ransac.min_inliers", o.min_inliers, 8, 1000000);
  o.min_parallax_deg = cfg.getInRange("ransac.min_parallax_deg", o.min_parallax_deg, 0.0, 90.0);
  return o;
}

std::string_view toString(RelativePoseResult::Status s) {
  switch (s) {
    case RelativePoseResult::Status::kOk:
      return "ok";
    case RelativePoseResult::Status::kTooFewMatches:
      return "too_few_matches";
    case RelativePoseResult::Status::kLowParallax:
      return "low_parallax";
    case RelativePoseResult::Status::kNoConsensus:
      return "no_consensus";
  }
  return "unknown";
}

RelativePoseEstimator::RelativePoseEstimator(const RelativePoseOptions& options)
    : options_(options),
      ransac_(std::make_unique<Ransac>(gpu::makeScoringBackend(options.backend))) {}
RelativePoseEstimator::~RelativePoseEstimator() = default;
RelativePoseEstimator::RelativePoseEstimator(RelativePoseEstimator&&) noexcept = default;
RelativePoseEstimator& RelativePoseEstimator::operator=(RelativePoseEstimator&&) noexcept = default;

std::string_view RelativePoseEstimator::backendName() const { return ransac_->backendName(); }

RelativePoseResult RelativePoseEstimator::estimate(const std::vector<Vec3>& bearings_prev,
                                                   const std::vector<Vec3>& bearings_cur) {
  using Status = RelativePoseResult::Status;
  RelativePoseResult result;
  const std::size_t n = std::min(bearings_prev.size(), bearings_cur.size());
  result.inliers.assign(n, 0);
  if (static_cast<int>(n) < std::max(8, options_.min_inliers)) {
    result.status = Status::kTooFewMatches;
    return result;
  }
  // Unit bearings; a non-finite or zero one becomes zero, which no test ever counts as inlier.
  std::vector<Vec3> b_prev(n), b_cur(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double np = bearings_prev[i].norm(), nc = bearings_cur[i].norm();
    const bool ok = std::isfinite(np) && std::isfinite(nc) && np > 0.0 && nc > 0.0;
    b_prev[i] = ok ? Vec3(bearings_prev[i] / np) : Vec3::Zero();
    b_cur[i] = ok ? Vec3(bearings_cur[i] / nc) : Vec3::Zero();
  }

  RansacOptions ro;
  ro.max_iterations = options_.max_iterations;
  ro.adaptive = options_.adaptive;
  ro.confidence = options_.confidence;
  ro.inlier_threshold_rad = options_.inlier_threshold_rad;
  ro.seed = options_.seed;
  const RansacResult rr = ransac_->run(b_prev, b_cur, ro);
  result.iterations = rr.iterations;
  if (!rr.found || rr.num_inliers < options_.min_inliers) {
    result.status = Status::kNoConsensus;
    return result;
  }

  // The refinement's ~20 short passes and the other per-match loops are split in two halves only
  // (one per core): finer tasks lost more to dispatch than they gained.
  const ParallelFor parallel_for = [this](int count, const std::function<void(int, int)>& fn) {
    ransac_->parallelFor(2, [&](int t0, int t1) {
      for (int t = t0; t < t1; ++t) fn(count * t / 2, count * (t + 1) / 2);
    });
  };
  // Two independent steps, one per pool thread (in sequence on the serial backend): the parallax
  // check and the least-squares refit on the consensus set.
  const double thr = options_.inlier_threshold_rad;
  const double min_parallax_rad = options_.min_parallax_deg / kRadToDeg;
  std::vector<std::uint8_t> rot_flags = rr.inliers;
  std::optional<Mat3> R_rot;
  double parallax_rot = 0.0;
  Mat3 E0 = rr.E;
  ransac_->parallelFor(2, [&](int task_begin, int task_end) {
    for (int task = task_begin; task < task_end; ++task) {
      if (task == 0) {
        // Parallax after removing the best pure rotation: a lower bound of the true
        // rotation-compensated parallax, and the only well-posed quantity when the baseline is
        // (near) zero. The consensus set of a (near) pure rotation may hold wrong matches that
        // happen to lie on the epipolar circles of a random t: trim them by their angle after
        // rotation, then refit.
        R_rot = rotationOnly(b_prev, b_cur, rot_flags);
        for (int pass = 0; pass < 3 && R_rot; ++pass) {
          const double gate =
              angleToChord(4.0 * thr + 3.0 * medianRotatedAngle(*R_rot, b_prev, b_cur, rot_flags));
          for (std::size_t i = 0; i < n; ++i)
            rot_flags[i] =
                rr.inliers[i] && rotatedChord(*R_rot, b_prev[i], b_cur[i]) < gate ? 1 : 0;
          if (auto refit = rotationOnly(b_prev, b_cur, rot_flags)) R_rot = refit;
        }
        if (R_rot) parallax_rot = medianRotatedAngle(*R_rot, b_prev, b_cur, rot_flags);
      } else {
        if (auto refit = eightPoint(b_prev, b_cur, rr.inliers)) E0 = *refit;
      }
    }
  });
  if (R_rot && parallax_rot < min_parallax_rad) {
    const Mat3 R = *R_rot;
    const double gate = angleToChord(4.0 * thr + 3.0 * parallax_rot);
    std::vector<std::uint8_t> flags(n, 0);
    for (std::size_t i = 0; i < n; ++i)
      flags[i] = rotatedChord(R, b_prev[i], b_cur[i]) < gate ? 1 : 0;
    result.num_inliers = countFlags(flags);
    if (result.num_inliers < options_.min_inliers) {
      result.status = Status::kNoConsensus;
      result.num_inliers = 0;
      return result;
    }
    result.status = Status::kLowParallax;
    result.R_cur_prev = R;
    result.t_cur_prev = Vec3::Zero();
    result.inliers = std::move(flags);
    result.median_parallax_deg = medianRotatedAngle(R, b_prev, b_cur, result.inliers) * kRadToDeg;
    return result;
  }

  // Cheirality on the refit's triangulated points, refine on the sphere (Cauchy loss at half the
  // threshold), re-select the inliers with the refined model, refine again.
  auto motion = selectByCheirality(E0, b_prev, b_cur, rr.inliers, nullptr, parallel_for);
  if (!motion) {
    result.status = Status::kNoConsensus;
    return result;
  }
  const double thr2 = thr * thr;
  std::vector<std::uint8_t> flags = rr.inliers;
  for (int round = 0; round < 2; ++round) {
    *motion =
        refineOnSphere(*motion, b_prev, b_cur, flags, round == 0 ? 6 : 4, 0.5 * thr, parallel_for);
    const Mat3 E = essentialFromMotion(motion->R_cur_prev, motion->t_cur_prev);
    parallel_for(static_cast<int>(n), [&](int i0, int i1) {
      for (int i = i0; i < i1; ++i) flags[i] = sphereError(E, b_prev[i], b_cur[i]) < thr2;
    });
  }
  result.num_inliers = countFlags(flags);
  if (result.num_inliers < options_.min_inliers || !motion->R_cur_prev.allFinite() ||
      !motion->t_cur_prev.allFinite()) {
    result.status = Status::kNoConsensus;
    result.num_inliers = 0;
    return result;
  }
  result.status = Status::kOk;
  result.R_cur_prev = motion->R_cur_prev;
  result.t_cur_prev = motion->t_cur_prev.normalized();
  result.inliers = std::move(flags);
  result.median_parallax_deg =
      medianRotatedAngle(result.R_cur_prev, b_prev, b_cur, result.inliers) * kRadToDeg;
  return result;
}

}  // namespace ovo::frontend
