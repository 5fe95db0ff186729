// Trajectory metrics with evo's semantics: association by time or index, ATE after alignment,
// RPE over consecutive pose pairs, KITTI-style drift, final yaw error and scale error.
// Everything here is numeric: no exceptions, nullopt when a metric is not defined.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/types.hpp"
#include "eval/align.hpp"

namespace ovo::eval {

/// Summary of an error array, as evo reports it (std is the population standard deviation,
/// median the mean of the two middle values for an even count).
struct Stats {
  std::size_t count = 0;
  double rmse = 0.0, mean = 0.0, median = 0.0, std = 0.0, min = 0.0, max = 0.0, sse = 0.0;
};
/// nullopt for an empty array.
std::optional<Stats> computeStats(const std::vector<double>& errors);

/// Two trajectories of equal length where pose i of one goes with pose i of the other.
struct Associated {
  Trajectory ref, est;
  std::size_t size() const { return ref.size(); }
};

/// evo's `associate_trajectories`: every stamp of the shorter trajectory (the reference when
/// both are equally long) is matched to the nearest stamp of the longer one and kept when
/// |dt| <= max_diff; ties go to the earlier stamp. As in evo, a stamp of the longer trajectory
/// can be used twice only when the shorter one repeats a stamp.
Associated associateByTime(const Trajectory& ref, const Trajectory& est,
                           Timestamp max_diff_ns = 20'000'000);
/// Pose i with pose i (KITTI files), over the first min(n_ref, n_est) poses.
Associated associateByIndex(const Trajectory& ref, const Trajectory& est);

/// Absolute trajectory error: translation error ||p_ref - S p_est|| after alignment S.
struct AteResult {
  AlignMode mode = AlignMode::kSE3;
  Similarity alignment;
  std::vector<double> errors_m;
  Stats trans_m;
  /// The same errors S p_est - p_ref resolved in the reference pose's body axes, RMSE per axis
  /// (ovo's body: x forward, y left, z up, so along-track, lateral, vertical). The squares add
  /// up to trans_m.rmse^2.
  Vec3 body_rmse_m = Vec3::Zero();
};
/// nullopt when the sizes differ, the trajectories are empty or the alignment is degenerate.
std::optional<AteResult> computeAte(const Associated& pairs, AlignMode mode);

/// RPE delta units: frames (`f`), metres of path (`m`), seconds (`s`).
enum class DeltaUnit { kFrames, kMeters, kSeconds };
/// "f", "m", "s" (nullopt otherwise).
std::optional<DeltaUnit> parseDeltaUnit(const std::string& name);
std::string deltaUnitName(DeltaUnit unit);

/// Consecutive pose pairs (i, j) `delta` apart, evo's `all_pairs=False` selection:
/// frames: ids 0, d, 2d, ... (d integer >= 1);
/// metres: walking along the path, an id is taken wherever the path length accumulated since the
///   previous id (since pose 0 for the first id) reaches delta (evo filter_pairs_by_path);
///   pose 0 itself is not an id, exactly as in evo;
/// seconds: the same with elapsed time instead of path length (an ovo extension; evo has none).
/// Pairs are consecutive ids. Empty when delta <= 0 or nothing reaches it.
std::vector<std::pair<std::size_t, std::size_t>> rpePairs(const Trajectory& trajectory,
                                                          double delta, DeltaUnit unit);

struct RpeOptions {
  double delta = 1.0;
  DeltaUnit unit = DeltaUnit::kFrames;
  /// evo picks the pairs on the estimate's path by default (`pairs_from_reference=False`;
  /// this is what reproduces its pair counts); true picks them on the reference path.
  bool pairs_from_reference = false;
};

/// Relative pose error, not aligned: E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q the reference and
/// P the estimate (Sturm et al., IROS 2012, eq. 1); trans = ||t(E)||, rot = angle(E) in degrees.
struct RpeResult {
  std::vector<std::pair<std::size_t, std::size_t>> id_pairs;
  std::vector<double> trans_m, rot_deg;
  Stats trans, rot;
};
/// nullopt when the sizes differ or no pair exists for the delta.
std::optional<RpeResult> computeRpe(const Associated& pairs, const RpeOptions& options);

/// Path length of the positions [m].
double pathLength(const Trajectory& trajectory);

/// KITTI odometry benchmark drift (Geiger et al., CVPR 2012; its devkit's evaluate_odometry):
/// for every 10th first frame and each segment length L, the first frame j whose reference path
/// length from i exceeds L gives E = (P_i^-1 P_j)^-1 (Q_i^-1 Q_j); the errors ||t(E)|| / L and
/// angle(E) / L are averaged over all segments. Lengths are 100, 200, ..., 800 m; when the
/// reference path is shorter than 800 m the lengths are 10 %, 20 %, ..., 80 % of its length
/// instead (`full_lengths` false), so that short runs still get a comparable number.
struct DriftResult {
  double trans_pct = 0.0;      // mean translation error per segment length [%]
  double rot_deg_per_m = 0.0;  // mean rotation error per segment length [deg/m]
  std::size_t segments = 0;
  bool full_lengths = true;  // the KITTI lengths 100..800 m were used
};
std::optional<DriftResult> kittiDrift(const Associated& pairs);

/// KITTI's segment errors at fixed lengths, reported per length as the field reports them: for
/// every 10th first frame, the segment to the first frame whose reference path length from it
/// exceeds L (the devkit's selection, as kittiDrift), E = (P_i^-1 P_j)^-1 (Q_i^-1 Q_j);
/// trans_pct = mean ||t(E)|| / L * 100, rot_deg_per_100m = mean angle(E) / L * 100. A length
/// that no segment reaches is left out.
struct SegmentError {
  double length_m = 0.0;
  std::size_t count = 0;
  double trans_pct = 0.0;
  double rot_deg_per_100m = 0.0;
};
inline const std::vector<double> kSegmentLengthsM = {10.0, 25.0, 50.0, 100.0, 200.0};
std::vector<SegmentError> segmentErrors(const Associated& pairs,
                                        const std::vector<double>& lengths_m = kSegmentLengthsM);

/// Odometry drift against the distance driven (the reference's path length): the estimate is
/// aligned on the first pose (alignFirstPose), then per pose the position error [m], the signed
/// heading error about `up_W` [deg] and the scale error [%] over the last `scale_window_m` of
/// path (100 (sum |dp_est| / sum |dp_ref| - 1) over steps 1 m apart along the reference; NaN
/// until that much path is behind).
struct DriftCurve {
  std::vector<double> distance_m, pos_err_m, yaw_err_deg, scale_err_pct;
};
inline constexpr double kDriftScaleWindowM = 25.0;  // driftAlongPath's default scale window
std::optional<DriftCurve> driftAlongPath(const Associated& pairs,
                                         double scale_window_m = kDriftScaleWindowM,
                                         const Vec3& up_W = Vec3::UnitZ());

/// Heading error at the last pose about the world's `up_W` axis [deg], signed in (-180, 180]:
/// the yaw of (R_align R_est) R_ref^T. Use alignFirstPose for odometry drift.
std::optional<double> finalYawErrorDeg(const Associated& pairs, const Similarity& alignment,
                                       const Vec3& up_W = Vec3::UnitZ());

/// Scale error of the estimate [%]: 100 (1/s - 1) with s the Sim(3) alignment scale
/// (p_ref = s R p_est + t), so +10 means the estimate is 10 % too large.
std::optional<double> scaleErrorPct(const Associated& pairs);

}  // namespace ovo::eval
