// Marginalisation of the window's oldest keyframe (DESIGN section 6): which of its landmarks end
// with it and which live on, re-anchored in a later keyframe (the policy), and the linear prior
// on the states it shares with the rest of the window (the linear algebra is
// factors::MarginalizationInfo's).
#pragma once

#include <memory>
#include <unordered_map>
#include <unordered_set>

#include "estimator/window/factors.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// Where a landmark that outlives its anchor keyframe is anchored next.
struct Reanchor {
  int kf_id = -1;
  Vec3 bearing_C = Vec3::UnitZ();
  double rho = 0.0;    // 1/m
  double row_s = 0.0;  // the new anchor sighting's row time (TrackObservation::row_s)
};

/// What marginalising the oldest keyframe does with the landmarks it anchors.
struct MarginalizationPlan {
  /// Landmarks seen by two more keyframes: re-anchored in the first later keyframe that sees them
  /// in front (their point kept).
  std::unordered_map<TrackId, Reanchor> reanchor;
  /// Landmarks anchored in the oldest keyframe whose inverse depth goes into the prior: those that
  /// end there (seen twice or more) and, with ReanchoredPrior::kLink, those re-anchored.
  std::unordered_set<TrackId> marginalized;
};

/// Marginalises the oldest keyframe of `map` (VINS-Mono / OKVIS style, DESIGN section 6): its
/// states, the factors on them and the previous prior go into the new prior, with the landmarks
/// it anchors that the plan marginalises (Schur-complemented out, each on its own as a 1x1
/// block): a landmark that ends there with all its factors; one re-anchored (link) with the
/// oldest keyframe's own measurements of it and the sighting of its new anchor, its other
/// measurements staying in the window. Every factor that leaves the window is recorded in the
/// ledger (prior or dropped: every one dropped when the marginalisation fails) and never built
/// again. Returns the new prior (null when the marginalisation failed; the caller then keeps a
/// pose prior instead).
std::shared_ptr<const factors::MarginalizationInfo> marginalizeOldest(
    WindowMap& map, const WindowModel& model, const WindowGauge& gauge,
    const MarginalizationPlan& plan, FactorLedger* ledger);

/// The plan for the oldest keyframe of `map`: landmarks that end there go into the prior when
/// seen twice or more, strongest first (LiDAR-linked, then most observed) up to
/// marginalize_max_landmarks (0: all); re-anchored ones by marginalize_reanchored.
MarginalizationPlan planMarginalization(const WindowMap& map, const SE3& T_B_C,
                                        const WindowOptions& options);

/// After the oldest keyframe (id oldest_id) has left the window: its landmarks are re-anchored as
/// planned, the others erased.
void reanchorLandmarks(WindowMap& map, int oldest_id, const MarginalizationPlan& plan);

}  // namespace ovo::estimator
