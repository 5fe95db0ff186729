#include "sim/track_truth.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "camera/camera.hpp"
#include "common/so3.hpp"
#include "common/stats.hpp"
#include "sim/simulation.hpp"

namespace ovo::sim {
namespace {

constexpr double kEdgeRadiusPx = 6.0;           // neighbours looked at around a track's first pixel
constexpr double kEdgeInverseDepthBend = 0.10;  // second difference of inverse depth (relative)
constexpr double kFarM = 10.0;                  // beyond: far away
constexpr double kMaxRangeM = 60.0;             // rays that meet nothing nearer see the sky
constexpr double kMaxStepRad = 0.01;            // steps further off are mismatches, not bias

// The time (s) at which the image row nearest to v of frame k was read.
double rowTimeAt(const Simulation& sim, int k, double v) {
  const int rows = camera::height(sim.camera());
  return sim.rowTime(k, std::clamp(static_cast<int>(std::lround(v)), 0, std::max(0, rows - 1)));
}

// The true camera pose when row v of frame k was read.
SE3 cameraPoseAtRow(const Simulation& sim, int k, double v) {
  return sim.trajectory().T_W_B(rowTimeAt(sim, k, v)) * sim.T_B_C();
}

// Where p_W appears in frame k: projected from the pose at its own row's time (two passes).
std::optional<Vec2> projectAtRow(const Simulation& sim, int k, const Vec3& p_W, SE3* T_W_C) {
  SE3 T = sim.trajectory().T_W_B(sim.frameTime(k)) * sim.T_B_C();
  std::optional<Vec2> px;
  for (int pass = 0; pass < 2; ++pass) {
    px = camera::project(sim.camera(), T.inverse() * p_W);
    if (!px) return std::nullopt;
    T = cameraPoseAtRow(sim, k, px->y());
  }
  px = camera::project(sim.camera(), T.inverse() * p_W);
  if (px && T_W_C) *T_W_C = T;
  return px;
}

}  // namespace

const char* trackKindName(TrackKind kind) {
  switch (kind) {
    case TrackKind::kDepthEdge:
      return "depth edge";
    case TrackKind::kFar:
      return "far (>10 m)";
    case TrackKind::kGround:
      return "ground";
    case TrackKind::kSurface:
      return "surface";
  }
  return "?";
}

TrackTruth::TrackTruth(const Simulation& sim) : sim_(sim) {
  for (auto& sums : rotation_sum_) sums.fill(Vec3::Zero());
}

void TrackTruth::addFrame(int k, const std::vector<TrackSighting>& sightings) {
  ++frames_;
  // The normal equations of each kind's (and all) steps: [0] every step, [1] but the first.
  std::array<std::array<Mat3, kTrackKinds + 1>, 2> H;
  std::array<std::array<Vec3, kTrackKinds + 1>, 2> g;
  std::array<std::array<int, kTrackKinds + 1>, 2> n{};
  for (int set = 0; set < 2; ++set) {
    H[set].fill(Mat3::Zero());
    g[set].fill(Vec3::Zero());
  }
  const SE3 T_W_C_frame = sim_.trajectory().T_W_B(sim_.frameTime(k)) * sim_.T_B_C();
  for (const TrackSighting& s : sightings) {
    auto [it, fresh] = tracks_.try_emplace(s.track_id);
    Track& tr = it->second;
    tr.last_frame = frames_;
    if (fresh) {
      const double t_s = rowTimeAt(sim_, k, s.px.y());
      const SE3 T_W_C = sim_.trajectory().T_W_B(t_s) * sim_.T_B_C();
      const auto p_W = sim_.castPixel(T_W_C, s.px, t_s, kMaxRangeM);
      if (!p_W) {
        ++unclassified_;
        continue;
      }
      const double depth = (*p_W - T_W_C.translation()).norm();
      const bool ground = sim_.world().onGround(*p_W);
      // A depth edge: around the pixel, a ray sees the sky, a surface of the other kind (ground
      // against the rest), or inverse depths that bend (a plane's are linear across the image,
      // so a slanted ground far ahead is no edge).
      bool edge = false;
      for (int a = 0; a < 4 && !edge; ++a) {
        const Vec2 d = kEdgeRadiusPx * Vec2(std::cos(a * M_PI / 4.0), std::sin(a * M_PI / 4.0));
        const auto p = sim_.castPixel(T_W_C, s.px + d, t_s, kMaxRangeM);
        const auto q = sim_.castPixel(T_W_C, s.px - d, t_s, kMaxRangeM);
        edge = !p || !q || sim_.world().onGround(*p) != ground ||
               sim_.world().onGround(*q) != ground ||
               std::abs(1.0 / (*p - T_W_C.translation()).norm() +
                        1.0 / (*q - T_W_C.translation()).norm() - 2.0 / depth) >
                   kEdgeInverseDepthBend / depth;
      }
      tr.kind = edge            ? TrackKind::kDepthEdge
                : depth > kFarM ? TrackKind::kFar
                : ground        ? TrackKind::kGround
                                : TrackKind::kSurface;
      tr.p_W = *p_W;
      tr.b0_W = (*p_W - T_W_C.translation()).normalized();
      tr.valid = true;
      tr.sightings = 1;
      ++started_[static_cast<int>(tr.kind)];
      continue;
    }
    if (!tr.valid) continue;
    const int age = tr.sightings++;
    SE3 T_W_C;
    const auto px_true = projectAtRow(sim_, k, tr.p_W, &T_W_C);
    const auto b_meas = camera::unproject(sim_.camera(), s.px);
    if (!px_true || !b_meas) {
      tr.valid = false;
      continue;
    }
    const int kind = static_cast<int>(tr.kind);
    // The step's bearing error, for the frame's apparent rotation.
    const Vec3 b_true = (T_W_C.inverse() * tr.p_W).normalized();
    const Vec3 err_C = b_meas->normalized() - b_true;
    const Vec3 step = err_C - tr.prev_err_C;
    tr.prev_err_C = err_C;
    const Vec3 e1 = b_true.unitOrthogonal(), e2 = b_true.cross(e1);
    Eigen::Matrix<double, 2, 3> E;
    E << e1.transpose(), e2.transpose();
    const Vec2 res = E * step;
    if (res.norm() < kMaxStepRad) {
      // A camera turned by the small rotation w sees b as b - w x b = b + [b]x w.
      const Eigen::Matrix<double, 2, 3> J = E * so3::hat(b_true);
      for (int set = 0; set < (age >= 2 ? 2 : 1); ++set) {
        for (int c : {kind, kTrackKinds}) {
          H[set][c] += J.transpose() * J;
          g[set][c] += J.transpose() * res;
          ++n[set][c];
        }
      }
    }
    const auto slot = std::find(kTrackErrorAges.begin(), kTrackErrorAges.end(), age);
    if (slot == kTrackErrorAges.end()) continue;
    const int a = static_cast<int>(slot - kTrackErrorAges.begin());
    const Vec2 e = s.px - *px_true;
    if (e.norm() > kTrackJumpPx) {
      ++jumped_[kind][a];
      continue;
    }
    Sample smp;
    smp.norm = e.norm();
    // Rotation-compensated flow: where the point is now less where its first bearing would be
    // after the rotation alone (a point at infinity).
    const auto px_rot = camera::project(sim_.camera(), T_W_C_frame.linear().transpose() * tr.b0_W);
    if (px_rot) {
      const Vec2 flow = *px_true - *px_rot;
      if (flow.norm() >= kTrackMinFlowPx) {
        const Vec2 u = flow.normalized();
        smp.along = e.dot(u);
        smp.across = u.x() * e.y() - u.y() * e.x();
        smp.has_flow = true;
      }
    }
    samples_[kind][a].push_back(smp);
  }
  // A track not seen in this frame has ended (a frontend does not resume tracks).
  std::erase_if(tracks_, [&](const auto& entry) { return entry.second.last_frame != frames_; });
  for (int set = 0; set < 2; ++set) {
    for (int c = 0; c <= kTrackKinds; ++c) {
      if (n[set][c] < TrackTruthReport::kMinStepsForRotation) continue;
      rotation_sum_[set][c] += H[set][c].ldlt().solve(g[set][c]);
      ++rotation_frames_[set][c];
      steps_[set][c] += n[set][c];
    }
  }
}

TrackTruthReport TrackTruth::report() const {
  TrackTruthReport r;
  r.frames = frames_;
  r.tracks_by_kind = started_;
  r.tracks_unclassified = unclassified_;
  for (int a = 0; a < static_cast<int>(kTrackErrorAges.size()); ++a) {
    std::vector<Sample> all;
    int all_jumped = 0;
    auto fill = [](const std::vector<Sample>& v, int jumped, TrackErrorCell& c) {
      std::vector<double> along, across, norm;
      c.n = static_cast<int>(v.size());
      c.jumped = jumped;
      double sa = 0.0, sc = 0.0;
      for (const Sample& s : v) {
        norm.push_back(s.norm);
        if (!s.has_flow) {
          ++c.no_flow;
          continue;
        }
        along.push_back(std::abs(s.along));
        across.push_back(std::abs(s.across));
        sa += s.along;
        sc += s.across;
      }
      if (!along.empty()) {
        c.mean_along = sa / static_cast<double>(along.size());
        c.mean_across = sc / static_cast<double>(across.size());
      }
      c.median_abs_along = upperMedian(along);
      c.median_abs_across = upperMedian(across);
      c.median_norm = upperMedian(norm);
      c.p90_norm = percentile(norm, 90.0);
    };
    for (int k = 0; k < kTrackKinds; ++k) {
      fill(samples_[k][a], jumped_[k][a], r.cells[k][a]);
      all.insert(all.end(), samples_[k][a].begin(), samples_[k][a].end());
      all_jumped += jumped_[k][a];
    }
    fill(all, all_jumped, r.cells[kTrackKinds][a]);
  }
  auto mean = [](const Vec3& sum, int frames) {
    return frames ? Vec3(sum / frames) : Vec3(Vec3::Zero());
  };
  auto perFrame = [](long steps, int frames) {
    return frames ? static_cast<double>(steps) / frames : 0.0;
  };
  for (int c = 0; c <= kTrackKinds; ++c) {
    r.rotation_frames[c] = rotation_frames_[0][c];
    r.rotation_per_frame[c] = mean(rotation_sum_[0][c], rotation_frames_[0][c]);
    r.steps_per_frame[c] = perFrame(steps_[0][c], rotation_frames_[0][c]);
    r.rotation_frames_later[c] = rotation_frames_[1][c];
    r.rotation_per_frame_later[c] = mean(rotation_sum_[1][c], rotation_frames_[1][c]);
    r.steps_per_frame_later[c] = perFrame(steps_[1][c], rotation_frames_[1][c]);
  }
  return r;
}

std::string formatTrackTruth(const TrackTruthReport& r) {
  std::string out = fmt::format(
      "{} frames; tracks started: {} next to a depth edge, {} far, {} ground, {} surface, {} "
      "unclassified\n",
      r.frames, r.tracks_by_kind[0], r.tracks_by_kind[1], r.tracks_by_kind[2], r.tracks_by_kind[3],
      r.tracks_unclassified);
  out += fmt::format("{:<12} {:>4} {:>7} {:>7} {:>10} {:>10} {:>10} {:>10} {:>8} {:>8}\n", "kind",
                     "age", "tracks", "jumped", "|along|50", "along avg", "|across|50",
                     "across avg", "|e|50", "|e|90");
  for (int k = 0; k <= kTrackKinds; ++k) {
    const char* name = k == kTrackKinds ? "all" : trackKindName(static_cast<TrackKind>(k));
    for (std::size_t a = 0; a < kTrackErrorAges.size(); ++a) {
      const TrackErrorCell& c = r.cells[k][a];
      out += fmt::format(
          "{:<12} {:>4} {:>7} {:>7} {:>10.3f} {:>+10.3f} {:>10.3f} {:>+10.3f} "
          "{:>8.3f} {:>8.3f}\n",
          name, kTrackErrorAges[a], c.n, c.jumped, c.median_abs_along, c.mean_along,
          c.median_abs_across, c.mean_across, c.median_norm, c.p90_norm);
    }
  }
  out += fmt::format(
      "apparent rotation per frame (camera x, y, z; urad), steps per frame:\n"
      "{:<12} {:>23}  {:>6}  {:>23}  {:>6}\n",
      "kind", "every step", "steps", "without first steps", "steps");
  for (int k = 0; k <= kTrackKinds; ++k) {
    const char* name = k == kTrackKinds ? "all" : trackKindName(static_cast<TrackKind>(k));
    const Vec3& w = r.rotation_per_frame[k];
    const Vec3& l = r.rotation_per_frame_later[k];
    out += fmt::format(
        "{:<12} {:>+7.1f} {:>+7.1f} {:>+7.1f}  {:>6.0f}  {:>+7.1f} {:>+7.1f} "
        "{:>+7.1f}  {:>6.0f}\n",
        name, 1e6 * w.x(), 1e6 * w.y(), 1e6 * w.z(), r.steps_per_frame[k], 1e6 * l.x(), 1e6 * l.y(),
        1e6 * l.z(), r.steps_per_frame_later[k]);
  }
  return out;
}

}  // namespace ovo::sim
