// The frame-to-frame chain shared by vo and kf: relative pose, unit-baseline points, scale.
#include "estimator/vo/chain.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "frontend/triangulation.hpp"

namespace ovo::estimator {

using Status = frontend::RelativePoseResult::Status;

VoChainOptions readVoChainOptions(const Config& cfg) {
  VoChainOptions o;
  o.max_reference_frames =
      cfg.getIntInRange("vo.max_reference_frames", o.max_reference_frames, 1, 1000);
  o.min_pairs = cfg.getIntInRange("vo.min_pairs", o.min_pairs, 8, 100000);
  o.bucket_px = cfg.getIntInRange("vo.bucket_px", o.bucket_px, 1, 10000);
  o.bucket_max = cfg.getIntInRange("vo.bucket_max", o.bucket_max, 0, 100000);
  return o;
}

VoChain::VoChain(const camera::Camera& camera, const Config& config)
    : options_(readVoChainOptions(config)),
      frontend_(camera, frontend::readFrontendOptions(config)),
      relative_pose_(frontend::readRelativePoseOptions(config)) {}

ChainStep VoChain::step(Timestamp t_ns, const cv::Mat& grey,
                        const std::optional<Mat3>& R_cur_prev_prior) {
  const frontend::FrontendResult r = frontend_.process(t_ns, grey, R_cur_prev_prior);
  ChainStep s;
  s.frontend_ms = r.timings.total_ms;
  s.first_frame = !r.relative_pose.has_value() || ref_frame_ < 0;
  if (s.first_frame) {
    ref_frame_ = r.frame_index;
    ref_t_ns_ = t_ns;
    s.ref_t_ns = t_ns;
    return s;
  }
  s.ref_t_ns = ref_t_ns_;

  // Pairs reference -> current from the tracks alive since the reference frame.
  struct Pair {
    Vec3 b_ref, b_cur;
    Vec2 px;
    int age;
    std::uint64_t id;
  };
  std::vector<Pair> pairs;
  const frontend::TrackManager& tracks = frontend_.tracks();
  for (const auto& obs : r.observations) {
    const frontend::Track* track = tracks.find(obs.track_id);
    if (!track || track->history.size() < 2) continue;
    for (auto it = track->history.rbegin(); it != track->history.rend(); ++it) {
      if (it->frame_index == ref_frame_) {
        pairs.push_back({it->bearing_C, obs.bearing_C, obs.px, obs.age, obs.track_id});
        break;
      }
      if (it->frame_index < ref_frame_) break;
    }
  }
  // Thin to a spatially even subset (oldest tracks first, then lowest id: deterministic).
  if (options_.bucket_max > 0) {
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
      return a.age != b.age ? a.age > b.age : a.id < b.id;
    });
    std::vector<Vec2> px;
    for (const auto& p : pairs) px.push_back(p.px);
    std::vector<Pair> kept;
    for (std::size_t i : thinToGrid(px, options_.bucket_px, options_.bucket_max))
      kept.push_back(pairs[i]);
    pairs = std::move(kept);
  }
  std::vector<Vec3> b_ref, b_cur;
  std::vector<Vec2> px_cur;
  std::vector<std::uint64_t> ids;
  for (const auto& p : pairs) {
    b_ref.push_back(p.b_ref);
    b_cur.push_back(p.b_cur);
    px_cur.push_back(p.px);
    ids.push_back(p.id);
  }
  s.matches = static_cast<int>(b_ref.size());
  const std::int64_t frames_since_ref = r.frame_index - ref_frame_;
  frontend::RelativePoseResult pose;
  if (static_cast<int>(b_ref.size()) >= options_.min_pairs) {
    pose = relative_pose_.estimate(b_ref, b_cur);
  } else {
    pose.status = Status::kTooFewMatches;
  }
  s.status = pose.status;
  s.R_cur_prev = pose.R_cur_prev;
  s.t_cur_prev_unit = pose.t_cur_prev;
  // Keep the reference while the parallax is small, up to max_reference_frames.
  s.reference_advances =
      !(s.status == Status::kLowParallax && frames_since_ref < options_.max_reference_frames);
  if (s.reference_advances) {
    ref_frame_ = r.frame_index;
    ref_t_ns_ = t_ns;
  }
  if (s.status != Status::kOk && s.status != Status::kLowParallax) return s;
  for (std::size_t i = 0; i < b_ref.size(); ++i) {
    if (i < pose.inliers.size() && !pose.inliers[i]) continue;
    s.bearings_prev.push_back(b_ref[i]);
    s.bearings_cur.push_back(b_cur[i]);
    s.px_cur.push_back(px_cur[i]);
    s.track_ids.push_back(ids[i]);
  }
  s.px_all_cur = s.px_cur;
  if (history_span_ns_ > 0) {
    s.track_history.resize(s.track_ids.size());
    for (std::size_t i = 0; i < s.track_ids.size(); ++i) {
      const frontend::Track* track = tracks.find(s.track_ids[i]);
      if (!track) continue;
      for (const auto& obs : track->history)
        if (t_ns - obs.t_ns <= history_span_ns_ && obs.t_ns < t_ns)
          s.track_history[i].push_back({obs.t_ns, obs.bearing_C});
    }
  }
  if (s.status == Status::kOk) {
    std::vector<std::uint8_t> valid;
    std::vector<Vec3> pts;
    triangulateUnit(s.R_cur_prev, s.t_cur_prev_unit, s.bearings_prev, s.bearings_cur, &pts, &valid);
    std::vector<Vec2> px;
    std::vector<Vec3> kept;
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (valid[i]) {
        kept.push_back(pts[i]);
        px.push_back(s.px_cur[i]);
      }
    s.points_cur_unit = std::move(kept);
    s.px_cur = std::move(px);
  }
  return s;
}

std::unique_ptr<ChainFrame> VoChain::track(Timestamp t_ns, const cv::Mat& grey,
                                           const std::optional<Mat3>& R_cur_prev_prior,
                                           std::chrono::steady_clock::time_point t0) {
  auto frame = std::make_unique<ChainFrame>();
  frame->t_ns = t_ns;
  frame->step = step(t_ns, grey, R_cur_prev_prior);
  frame->tracks = currentTracks();
  frame->frontend_ms = msSince(t0);
  return frame;
}

std::vector<TrackPx> VoChain::currentTracks() const {
  std::vector<TrackPx> out;
  for (const auto& obs : frontend_.tracks().currentObservations())
    if (obs.age >= 2) out.push_back({obs.track_id, obs.px, obs.age});
  return out;
}

std::vector<std::size_t> thinToGrid(const std::vector<Vec2>& px, int cell_px, int per_cell) {
  std::unordered_map<std::int64_t, int> count;
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < px.size(); ++i) {
    const std::int64_t cell = (static_cast<std::int64_t>(px[i].y()) / cell_px) * 100000 +
                              static_cast<std::int64_t>(px[i].x()) / cell_px;
    if (count[cell]++ < per_cell) kept.push_back(i);
  }
  return kept;
}

std::optional<Vec3> translationGivenRotation(const Mat3& R_cur_prev,
                                             const std::vector<Vec3>& bearings_prev,
                                             const std::vector<Vec3>& bearings_cur) {
  const std::size_t n = bearings_prev.size();
  if (n < 3 || bearings_cur.size() != n) return std::nullopt;
  // b_c^T [t]x R b_p = t . (R b_p x b_c) = 0 for every pair.
  Mat3 A = Mat3::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 row = (R_cur_prev * bearings_prev[i]).cross(bearings_cur[i]);
    A += row * row.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Mat3> es(A);
  if (es.info() != Eigen::Success) return std::nullopt;
  // Well-posed when the smallest eigenvalue is clearly separated from the next one.
  if (!(es.eigenvalues()(1) > 1e-12) || es.eigenvalues()(0) > 0.5 * es.eigenvalues()(1))
    return std::nullopt;
  Vec3 t = es.eigenvectors().col(0).normalized();
  // Sign: the majority of points in front along both bearings.
  int front = 0, back = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto p = frontend::triangulateMidpoint(R_cur_prev, t, bearings_prev[i], bearings_cur[i]);
    if (!p) continue;
    if (p->depth_prev > 0 && p->depth_cur > 0) ++front;
    if (p->depth_prev < 0 && p->depth_cur < 0) ++back;
  }
  if (back > front) t = -t;
  if (front == 0 && back == 0) return std::nullopt;
  return t;
}

void triangulateUnit(const Mat3& R_cur_prev, const Vec3& t_unit,
                     const std::vector<Vec3>& bearings_prev, const std::vector<Vec3>& bearings_cur,
                     std::vector<Vec3>* points_cur, std::vector<std::uint8_t>* valid) {
  points_cur->assign(bearings_prev.size(), Vec3::Zero());
  valid->assign(bearings_prev.size(), 0);
  for (std::size_t i = 0; i < bearings_prev.size(); ++i) {
    const auto p =
        frontend::triangulateMidpoint(R_cur_prev, t_unit, bearings_prev[i], bearings_cur[i], 1e-4);
    if (!p || !(p->depth_prev > 0) || !(p->depth_cur > 0)) continue;
    // Too far to be informative at unit baseline (parallax below ~0.5 deg).
    if (p->depth_cur > 120.0) continue;
    (*points_cur)[i] = p->depth_cur * bearings_cur[i];
    (*valid)[i] = 1;
  }
}

std::optional<double> groundPlaneScale(const ChainStep& step, const Vec3& up_C,
                                       double camera_height_m, const GroundPlaneOptions& options) {
  if (step.status != Status::kOk || step.points_cur_unit.empty()) return std::nullopt;
  const auto plane = fitGroundPlane(step.points_cur_unit, up_C, options);
  if (!plane || !(plane->height > 1e-9)) return std::nullopt;
  const double scale = camera_height_m / plane->height;
  if (!std::isfinite(scale)) return std::nullopt;
  return scale;
}

SE3 chainPose(const SE3& T_W_Bprev, const SE3& T_B_C, const Mat3& R_cur_prev,
              const Vec3& t_cur_prev) {
  SE3 T_Ccur_Cprev = SE3::Identity();
  T_Ccur_Cprev.linear() = R_cur_prev;
  T_Ccur_Cprev.translation() = t_cur_prev;
  return T_W_Bprev * T_B_C * T_Ccur_Cprev.inverse() * T_B_C.inverse();
}

}  // namespace ovo::estimator
