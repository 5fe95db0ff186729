// Do tracks stay on the physical point they started on? On a rendered vineyard row, a track's
// first pixel is cast onto the terrain (the simulator's exact geometry and the true pose); every
// later pixel of the track is compared with that ground point's true projection. A track that
// continues by measured flow accumulates the per-frame sub-pixel error as a random walk; a match
// to a neighbouring feature offsets the rest of the track (the window estimator sees both).
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera/camera.hpp"
#include "common/config.hpp"
#include "common/stats.hpp"
#include "frontend/frontend.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "tests/test_support.hpp"

namespace ovo::frontend {
namespace {

struct DriftStats {
  double median_one_frame_px = 0.0;  // median |error| one frame after the start
  double median_ten_frames_px = 0.0;
  double far_off_fraction = 0.0;  // tracks more than 2 px off after ten frames
  int tracks_ten_frames = 0;
};

// The first 4.5 s of the row (the robot stands still for the first 0.5 s), rendered once.
struct RenderedRow {
  std::unique_ptr<sim::Simulation> sim;
  std::vector<cv::Mat> frames;
};

const RenderedRow& renderedRow() {
  static const RenderedRow row = [] {
    Config scenario_cfg = Config::load(test::sourcePath("configs/sim/vineyard_row.yaml"));
    scenario_cfg.applyOverrides({"duration_s=4.5"});
    RenderedRow r;
    r.sim = std::make_unique<sim::Simulation>(sim::readScenario(scenario_cfg));
    r.frames.resize(r.sim->frameCount());
    tbb::parallel_for(0, r.sim->frameCount(), [&](int k) { r.frames[k] = r.sim->renderFrame(k); });
    return r;
  }();
  return row;
}

// Runs the frontend over the rendered row from frame 10 (true rotation as its prior) and hands
// each frame's time, true camera pose and result to f.
void forEachFrame(const RenderedRow& row, Frontend& frontend,
                  const std::function<void(double, const SE3&, const FrontendResult&)>& f) {
  const sim::Simulation& sim = *row.sim;
  std::optional<SE3> prev_T_W_C;
  for (int k = 10; k < sim.frameCount(); ++k) {
    const double t_s = sim.frameTime(k);
    const SE3 T_W_C = sim.trajectory().T_W_B(t_s) * sim.T_B_C();
    std::optional<Mat3> prior;
    if (prev_T_W_C) prior = T_W_C.linear().transpose() * prev_T_W_C->linear();
    prev_T_W_C = T_W_C;
    f(t_s, T_W_C, frontend.process(sim.frameStamp(k), row.frames[k], prior));
  }
}

// Rays that meet nothing within this range see the sky.
constexpr double kRayRangeM = 30.0;

// Next to a depth edge: one of the 8 pixels 6 px around px sees nothing, or something that
// `differs` from the point px sees.
bool nextToDepthEdge(const sim::Simulation& sim, const SE3& T_W_C, double t_s, const Vec2& px,
                     const std::function<bool(const Vec3&)>& differs) {
  for (int a = 0; a < 8; ++a) {
    const auto q =
        sim.castPixel(T_W_C, px + 6.0 * Vec2(std::cos(a * M_PI / 4.0), std::sin(a * M_PI / 4.0)),
                      t_s, kRayRangeM);
    if (!q || differs(*q)) return true;
  }
  return false;
}

DriftStats measureDrift(const std::vector<std::string>& frontend_sets) {
  const RenderedRow& row = renderedRow();
  const sim::Simulation& sim = *row.sim;
  Config cfg;
  cfg.applyOverrides(frontend_sets);
  Frontend frontend(sim.camera(), readFrontendOptions(cfg));
  std::map<std::uint64_t, Vec3> ground_W;  // track -> where its first ray meets the terrain
  std::vector<double> one, ten;
  int far_off = 0;
  forEachFrame(row, frontend, [&](double t_s, const SE3& T_W_C, const FrontendResult& r) {
    for (const FeatureObservation& o : r.observations) {
      if (o.age == 1) {
        const auto p_W = sim.castRay(T_W_C, o.bearing_C, t_s, kRayRangeM);
        if (p_W && sim.world().onGround(*p_W)) ground_W[o.track_id] = *p_W;
        continue;
      }
      const auto g = ground_W.find(o.track_id);
      if (g == ground_W.end() || (o.age != 2 && o.age != 11)) continue;
      const auto px = camera::project(sim.camera(), T_W_C.inverse() * g->second);
      if (!px) continue;
      const double err = (o.px - *px).norm();
      if (o.age == 2) {
        one.push_back(err);
      } else {
        ten.push_back(err);
        far_off += err > 2.0;
      }
    }
  });
  DriftStats s;
  s.median_one_frame_px = upperMedian(one);
  s.median_ten_frames_px = upperMedian(ten);
  s.tracks_ten_frames = static_cast<int>(ten.size());
  s.far_off_fraction = ten.empty() ? 1.0 : static_cast<double>(far_off) / ten.size();
  return s;
}

// Mean error of one track step along the true flow (px), per band of true flow (0.1-0.3, 0.3-0.5,
// 0.5-1, 1-2 and 2-4 px per frame), for ground points whose 6 px surroundings are all ground
// ("clean") and for those next to a nearer or farther surface (a trunk, the canopy's underside,
// the sky: "edge").
constexpr int kFlowBands = 5;
constexpr double kFlowBandEdges[kFlowBands + 1] = {0.1, 0.3, 0.5, 1.0, 2.0, 4.0};

struct StepBias {
  double clean[kFlowBands] = {}, edge[kFlowBands] = {};
  int clean_n[kFlowBands] = {}, edge_n[kFlowBands] = {};
};

StepBias measureStepBias() {
  const RenderedRow& row = renderedRow();
  const sim::Simulation& sim = *row.sim;
  Frontend frontend(sim.camera(), readFrontendOptions(Config{}));
  struct Start {
    Vec2 px;
    Vec3 p_W;
    bool edge;
  };
  std::map<std::uint64_t, Start> prev;
  StepBias out;
  forEachFrame(row, frontend, [&](double t_s, const SE3& T_W_C, const FrontendResult& r) {
    std::map<std::uint64_t, Start> next;
    for (const FeatureObservation& o : r.observations) {
      const auto it = prev.find(o.track_id);
      if (it != prev.end() && o.age >= 2) {
        const auto px = camera::project(sim.camera(), T_W_C.inverse() * it->second.p_W);
        if (px) {
          const Vec2 flow = *px - it->second.px;
          const Vec2 err = (o.px - it->second.px) - flow;
          const double f = flow.norm();
          int band = -1;
          for (int b = 0; b < kFlowBands; ++b)
            if (f >= kFlowBandEdges[b] && f < kFlowBandEdges[b + 1]) band = b;
          if (band >= 0 && err.norm() < 1.5) {
            const double along = err.dot(flow / f);
            if (it->second.edge) {
              out.edge[band] += along;
              ++out.edge_n[band];
            } else {
              out.clean[band] += along;
              ++out.clean_n[band];
            }
          }
        }
      }
      const auto p_W = sim.castPixel(T_W_C, o.px, t_s, kRayRangeM);
      if (!p_W || !sim.world().onGround(*p_W)) continue;
      const bool edge = nextToDepthEdge(sim, T_W_C, t_s, o.px,
                                        [&](const Vec3& q) { return !sim.world().onGround(q); });
      next[o.track_id] = {o.px, *p_W, edge};
    }
    prev.swap(next);
  });
  for (int b = 0; b < kFlowBands; ++b) {
    if (out.clean_n[b]) out.clean[b] /= out.clean_n[b];
    if (out.edge_n[b]) out.edge[b] /= out.edge_n[b];
  }
  return out;
}

// The steps of clean ground tracks carry no bias along the flow. Without the Lucas-Kanade step
// (frontend.track_refine false) those under half a pixel fall short, as a sub-pixel estimator
// that locks to whole pixels does: the parabola through three SSD samples (frontend.subpixel=cost)
// gives -0.032 and -0.035 px for flows of 0.1-0.3 and 0.3-0.5 px, 9-16 % of such a flow
// (measured; subpixel=response -0.050 and -0.080, integer matching -0.030 and -0.053). The step
// (the default, 9x9 patch) leaves -0.008 and -0.009 px. Those next to a depth edge step +0.08 to
// +0.30 px further than their ground point every frame (+0.24 to +0.30 without the step;
// measured, printed, not asserted): a temporary measurement put them between the ground point's
// motion and the nearer surface's (median 0.7 of the way), so no single point explains such a
// track (nor does a robust Lucas-Kanade step fix them: Huber weights on its residuals at 3 or 6
// grey levels left them at +0.08 to +0.29 px: such a feature is possibly a corner that the
// occlusion itself forms, a T-junction, which moves with neither surface and looks the same). They
// are the far ground's whole flow bias; that tracks next to depth edges cause the
// steady pitch drift of vo and the window on the rows is measured below
// (TracksAwayFromDepthEdgesImplyNoSteadyRotation). Their patches match as well as clean ones
// (same normalised residual), so a residual test cannot find them. Nor does the change of their
// patch since the track's first frame (an affine and gain fit, Shi and Tomasi's feature
// monitor): on this row its residual is larger next to depth edges (median 0.31-0.40 of the
// patch's contrast against 0.16-0.24 after 2-12 frames), but the two overlap so much that ending
// tracks at 0.2-0.6 leaves the rotation they imply (below) at 40-52 urad per frame about the
// camera's y axis, 41 with every track (measured with a temporary harness).
TEST(TrackDrift, CleanGroundStepsAreUnbiasedAlongTheFlow) {
  const StepBias s = measureStepBias();
  const char* band[kFlowBands] = {"0.1-0.3", "0.3-0.5", "0.5-1", "1-2", "2-4"};
  // Measured: -0.008, -0.009, +0.010, +0.003, +0.004 px. The bound holds the whole-pixel lock to
  // what the Lucas-Kanade step leaves (without it, -0.032, -0.035, +0.022 px fail).
  const double bound[kFlowBands] = {0.02, 0.02, 0.02, 0.02, 0.02};
  const int min_steps[kFlowBands] = {4000, 4000, 5000, 5000, 5000};  // measured 4606 and more
  for (int b = 0; b < kFlowBands; ++b) {
    std::printf("flow %s px: clean %+.3f px (%d steps), next to a depth edge %+.3f px (%d)\n",
                band[b], s.clean[b], s.clean_n[b], s.edge[b], s.edge_n[b]);
    RecordProperty(std::string("edge_bias_px_") + band[b], std::to_string(s.edge[b]));
    RecordProperty(std::string("clean_bias_px_") + band[b], std::to_string(s.clean[b]));
    ASSERT_GT(s.clean_n[b], min_steps[b]);
    EXPECT_LT(std::abs(s.clean[b]), bound[b]) << band[b];
  }
}

// The camera rotation each frame's tracks imply, by kind of track. For every track continued into
// a frame, the point its previous pixel saw (cast onto the simulator's geometry from the true
// pose) is projected from the frame's true pose; the small rotation that best moves those true
// bearings onto the measured ones (least squares on the tangent planes, translation held at the
// truth) is the frame's apparent rotation error. Averaged over the frames, it is the rotation
// bias the tracks hand an estimator: a steady one is a steady drift of the vision's attitude.
struct RotationBias {
  // Camera frame, rad per frame.
  Vec3 clean = Vec3::Zero(), edge = Vec3::Zero(), all = Vec3::Zero();
  int frames = 0;
  double clean_per_frame = 0.0, edge_per_frame = 0.0;  // tracks used per frame
};

RotationBias measureRotationBias() {
  const RenderedRow& row = renderedRow();
  const sim::Simulation& sim = *row.sim;
  Frontend frontend(sim.camera(), readFrontendOptions(Config{}));
  struct Seen {
    Vec3 p_W;
    bool edge;
  };
  std::map<std::uint64_t, Seen> prev;
  RotationBias out;
  long clean_n = 0, edge_n = 0;
  forEachFrame(row, frontend, [&](double t_s, const SE3& T_W_C, const FrontendResult& r) {
    Mat3 H[2] = {Mat3::Zero(), Mat3::Zero()};
    Vec3 g[2] = {Vec3::Zero(), Vec3::Zero()};
    int n[2] = {0, 0};
    const SE3 T_C_W = T_W_C.inverse();
    std::map<std::uint64_t, Seen> next;
    for (const FeatureObservation& o : r.observations) {
      const auto it = prev.find(o.track_id);
      if (it != prev.end()) {
        const Vec3 b = (T_C_W * it->second.p_W).normalized();
        const Vec3 e1 = b.unitOrthogonal(), e2 = b.cross(e1);
        Eigen::Matrix<double, 2, 3> E;
        E << e1.transpose(), e2.transpose();
        const Vec2 res = E * (o.bearing_C.normalized() - b);
        if (res.norm() < 0.01) {  // mismatches (0.6 deg) are no bias
          // A camera turned by the small rotation w sees b as b - w x b = b + [b]x w.
          Mat3 bx;
          bx << 0, -b.z(), b.y(), b.z(), 0, -b.x(), -b.y(), b.x(), 0;
          const Eigen::Matrix<double, 2, 3> J = E * bx;
          const int k = it->second.edge ? 1 : 0;
          H[k] += J.transpose() * J;
          g[k] += J.transpose() * res;
          ++n[k];
        }
      }
      const auto p_W = sim.castPixel(T_W_C, o.px, t_s, kRayRangeM);
      if (!p_W) continue;
      // Next to a depth edge: a point 6 px away lies more than 10 % nearer or farther (or is sky).
      const double depth = (*p_W - T_W_C.translation()).norm();
      const bool edge = nextToDepthEdge(sim, T_W_C, t_s, o.px, [&](const Vec3& q) {
        return std::abs((q - T_W_C.translation()).norm() - depth) > 0.1 * depth;
      });
      next[o.track_id] = {*p_W, edge};
    }
    prev.swap(next);
    if (n[0] < 100 || n[1] < 100) return;
    out.clean += H[0].ldlt().solve(g[0]);
    out.edge += H[1].ldlt().solve(g[1]);
    out.all += (H[0] + H[1]).ldlt().solve(g[0] + g[1]);
    clean_n += n[0];
    edge_n += n[1];
    ++out.frames;
  });
  if (out.frames > 0) {
    out.clean /= out.frames;
    out.edge /= out.frames;
    out.all /= out.frames;
    out.clean_per_frame = static_cast<double>(clean_n) / out.frames;
    out.edge_per_frame = static_cast<double>(edge_n) / out.frames;
  }
  return out;
}

// Tracks on a surface that continues around them (the ground, the inside of a leaf or a post)
// imply no steady rotation: the camera model, the sub-pixel matching and the chaining of steps
// hold no bias of their own. Those next to a depth edge (most of the canopy's tracks: leaves in
// front of leaves) imply +53, +92, -19 urad per frame about the camera's x, y, z axes, and all
// tracks together +19, +41, +14 (measured; printed, not asserted; without the Lucas-Kanade step
// +53, +91, -19 and +17, +41, +13: it does not help them). At 20 Hz, 60 urad per frame is
// the 0.07 deg/s pitch drift of vo and of the vision-only window on the rows. That these tracks
// cause it was measured with a temporary harness (the window fed the frontend's tracks on the
// first 16 s of the row, with the simulator's geometry at hand): pitch +1.38 deg after 12 s as
// is; -0.24 deg with every observation within 12 px of a depth edge left out; -0.11 deg with
// every bearing replaced by its true direction (ATE 10.2, 6.5 and 1.9 mm).
// Tried, not kept (temporary harness and switches): a track step whose rotation-compensated flow
// (gyro rotation) differs by more than 25 % from that of a neighbouring track within 12 px flags
// 43 % of the depth-edge steps and 19 % of the clean ones; the unflagged steps imply -0.9, +34.5,
// +16.6 urad per frame (all: +18.7, +40.7, +13.7), so the flag finds what drives the pitch. Used
// in the window, leaving tracks flagged in more than 30 % of their frames out of new landmarks,
// it did not move the gyro bias (about the body's y axis still 100-110 deg/h off on vineyard_row
// and steep_slope seed 5) and cost accuracy (10 runs' ATE sum 0.064 -> 0.084 m). Nor did a 3x
// sigma on the window's bearing steps over which the flag fired: the bias stayed (vineyard_row
// 103 deg/h off); the 21 runs went 0.1255 -> 0.1230 m, 2x over kf on 17 instead of 15, but
// steep_slope seed 5 fell behind kf (12.0 against 10.8 mm): a reshuffle within the runs' spread.
TEST(TrackDrift, TracksAwayFromDepthEdgesImplyNoSteadyRotation) {
  const RotationBias s = measureRotationBias();
  std::printf(
      "apparent rotation per frame (camera x, y, z; urad): clean %+.1f %+.1f %+.1f (%.0f "
      "tracks), next to a depth edge %+.1f %+.1f %+.1f (%.0f tracks), %d frames\n",
      1e6 * s.clean.x(), 1e6 * s.clean.y(), 1e6 * s.clean.z(), s.clean_per_frame, 1e6 * s.edge.x(),
      1e6 * s.edge.y(), 1e6 * s.edge.z(), s.edge_per_frame, s.frames);
  std::printf("all tracks together %+.1f %+.1f %+.1f urad\n", 1e6 * s.all.x(), 1e6 * s.all.y(),
              1e6 * s.all.z());
  RecordProperty("edge_x_urad_per_frame", std::to_string(1e6 * s.edge.x()));
  RecordProperty("all_x_urad_per_frame", std::to_string(1e6 * s.all.x()));
  ASSERT_GT(s.frames, 60);
  ASSERT_GT(s.clean_per_frame, 1000.0);
  // Measured: +1.8, +0.7, +0.6 urad per frame (+0.2, +2.6, +1.3 without the Lucas-Kanade step). A
  // per-frame error of 0.02 px in the far ground's flow would be ~100 urad.
  EXPECT_LT(s.clean.norm(), 10e-6);
}

TEST(TrackDrift, GroundTracksStayNearTheirPointOnARenderedRow) {
  const DriftStats s = measureDrift({});
  RecordProperty("median_one_frame_px", std::to_string(s.median_one_frame_px));
  RecordProperty("median_ten_frames_px", std::to_string(s.median_ten_frames_px));
  RecordProperty("far_off_fraction", std::to_string(s.far_off_fraction));
  std::printf(
      "median error one frame on %.3f px, ten frames on %.3f px; %.1f %% of %d tracks > 2 px\n",
      s.median_one_frame_px, s.median_ten_frames_px, 100.0 * s.far_off_fraction,
      s.tracks_ten_frames);
  ASSERT_GT(s.tracks_ten_frames, 2000);  // long tracks exist on the ground
  // Measured: 0.16 px, 0.40 px (a random walk of ~0.13 px per frame), 8.5 %; without the
  // Lucas-Kanade step 0.22 px, 0.78 px, 10.9 %, which fail.
  EXPECT_LT(s.median_one_frame_px, 0.18);
  EXPECT_LT(s.median_ten_frames_px, 0.6);
  EXPECT_LT(s.far_off_fraction, 0.10);
}

TEST(TrackDrift, EpipolarGateEndsTracksThatJumped) {
  const DriftStats gated = measureDrift({"frontend.track_epipolar_gate_rad=1e-3"});
  const DriftStats open = measureDrift({});
  std::printf("far off after ten frames: %.1f %% gated, %.1f %% without the gate\n",
              100.0 * gated.far_off_fraction, 100.0 * open.far_off_fraction);
  // Without the gate, tracks that jumped to a neighbouring feature live on, far off their point.
  EXPECT_GT(open.far_off_fraction, 1.3 * gated.far_off_fraction);
  EXPECT_GT(open.tracks_ten_frames, gated.tracks_ten_frames);
}

TEST(TrackDrift, LucasKanadeStepsKeepGroundTracksCloser) {
  const DriftStats refined = measureDrift({});  // the default
  const DriftStats plain = measureDrift({"frontend.track_refine=false"});
  std::printf(
      "median error one frame on %.3f px refined, %.3f px plain; ten frames on %.3f, %.3f\n",
      refined.median_one_frame_px, plain.median_one_frame_px, refined.median_ten_frames_px,
      plain.median_ten_frames_px);
  ASSERT_GT(refined.tracks_ten_frames, 2000);
  EXPECT_LT(refined.median_one_frame_px, plain.median_one_frame_px);
  // Measured: 0.40 against 0.78 px after ten frames (one frame: 0.16 against 0.22 px).
  EXPECT_LT(refined.median_ten_frames_px, 0.7 * plain.median_ten_frames_px);
}

// The step's two gates (off by default, docs/tracks.md): a step that does not align, or that
// aligned back misses its start by more than 0.1 px, ends the track. Tracks that wandered off
// their point end with them; the ten-frame error of those that stay is lower (measured: 3.4 %
// against 8.5 % more than 2 px off, median 0.325 against 0.404 px).
TEST(TrackDrift, TheStepsGatesEndTracksThatWandered) {
  const DriftStats open = measureDrift({});
  const DriftStats gated = measureDrift(
      {"frontend.track_refine_forward_backward_px=0.1", "frontend.track_refine_required=true"});
  std::printf("ten frames on: %.3f px, %.1f %% > 2 px gated; %.3f px, %.1f %% open\n",
              gated.median_ten_frames_px, 100.0 * gated.far_off_fraction, open.median_ten_frames_px,
              100.0 * open.far_off_fraction);
  ASSERT_GT(gated.tracks_ten_frames, 2000);
  EXPECT_LT(gated.far_off_fraction, 0.7 * open.far_off_fraction);
  EXPECT_LT(gated.median_ten_frames_px, open.median_ten_frames_px);
}

}  // namespace
}  // namespace ovo::frontend
