// Marginalising the oldest keyframe: the landmarks' fates and the linear prior.
#include "estimator/window/marginalize.hpp"

#include <algorithm>
#include <unordered_set>
#include <vector>

namespace ovo::estimator {

std::shared_ptr<const factors::MarginalizationInfo> marginalizeOldest(
    WindowMap& map, const WindowModel& model, const WindowGauge& gauge,
    const MarginalizationPlan& plan, FactorLedger* ledger) {
  if (map.keyframes.size() < 2) return nullptr;
  Keyframe* oldest = map.keyframes.front().get();
  std::vector<Keyframe*> kfs;
  for (auto& kf : map.keyframes) kfs.push_back(kf.get());

  // Only the landmarks the oldest keyframe sees or anchors can have factors on its states or end
  // with it (a LiDAR range pairs a beam with a sighting).
  std::vector<FactorSpec> all =
      buildFactors(kfs, map.landmarks, model, gauge, ledger, map.time_offset_s,
                   map.camera_height_offset_m, map.gravity, oldest);
  auto info = std::make_shared<factors::MarginalizationInfo>();
  for (Keyframe* kf : kfs) {
    info->setQuaternionBlock(kf->q_W_B);
    if (tiedRotations(model)) info->setQuaternionBlock(kf->q_W_G);
  }

  std::unordered_set<const double*> drop = {oldest->q_W_B,   oldest->q_W_G,
                                            oldest->p_W_B,   oldest->b_g,
                                            oldest->terrain, oldest->height_offset_m};
  for (auto& [id, lm] : map.landmarks)
    if (lm.anchor_kf == oldest->id && plan.marginalized.count(id)) drop.insert(lm.rho);

  using Fate = FactorLedger::Fate;
  int added = 0;
  // The fates are recorded once the prior is made: a prior that fails holds none of them.
  std::vector<std::pair<FactorKey, Fate>> fates;
  for (const FactorSpec& f : all) {
    bool touches = false;
    for (const double* b : f.blocks) touches = touches || drop.count(b) > 0;
    // A landmark anchored in the oldest keyframe and not re-anchored ends here: its factors leave
    // the window with it, also those on its inverse depth alone (the anchor's own LiDAR range,
    // its camera-height factor), which touch none of the dropped states when it is not
    // marginalised.
    bool ends_here = false;
    if (f.track >= 0 && !plan.reanchor.count(f.track)) {
      const auto it = map.landmarks.find(f.track);
      ends_here = it != map.landmarks.end() && it->second.anchor_kf == oldest->id;
    }
    // The previous prior always goes on into the new one, whether it touches the oldest
    // keyframe's states or not.
    if (!touches && !ends_here && f.kind != FactorKind::kMarginal) continue;  // stays
    Fate fate = Fate::kPrior;
    if (f.track >= 0) {
      const auto it = map.landmarks.find(f.track);
      const bool anchored_here = it != map.landmarks.end() && it->second.anchor_kf == oldest->id;
      const auto re = plan.reanchor.find(f.track);
      if (anchored_here && re != plan.reanchor.end()) {
        // A landmark that lives on: the oldest keyframe's own measurements of it and the sighting
        // that links it to its new anchor leave the window; its other measurements (the new
        // anchor's LiDAR range among them) stay, against the new anchor.
        const bool own = f.kf_id == oldest->id;
        const bool link = f.kind == FactorKind::kBearing && f.kf_id == re->second.kf_id;
        if (!own && !link) continue;
      }
      // A landmark anchored elsewhere would put its rho into the prior; one not planned for the
      // prior ends without it.
      if (!anchored_here || !plan.marginalized.count(f.track)) fate = Fate::kDropped;
    }
    if (fate == Fate::kPrior) {
      std::vector<int> drop_idx;
      for (std::size_t k = 0; k < f.blocks.size(); ++k)
        if (drop.count(f.blocks[k])) drop_idx.push_back(static_cast<int>(k));
      if (info->addResidualBlock(f.cost.get(), f.loss.get(), f.blocks, drop_idx))
        ++added;
      else
        fate = Fate::kDropped;
    }
    if (f.kind != FactorKind::kMarginal) fates.emplace_back(f.key(), fate);
  }
  const bool made = added > 0 && info->marginalize();
  if (ledger != nullptr)
    for (const auto& [key, fate] : fates) ledger->record(key, made ? fate : Fate::kDropped);
  if (!made) return nullptr;
  return info;
}

MarginalizationPlan planMarginalization(const WindowMap& map, const SE3& T_B_C,
                                        const WindowOptions& options) {
  MarginalizationPlan plan;
  const Keyframe* oldest = map.keyframes.front().get();
  // Landmarks seen twice more live on, re-anchored in the first later keyframe that sees them
  // in front (their point kept).
  std::unordered_map<TrackId, Reanchor>& reanchor = plan.reanchor;
  for (const auto& [id, lm] : map.landmarks) {
    if (lm.anchor_kf != oldest->id || map.observationCount(id) - 1 < 2) continue;
    const auto p_W = map.pointW(lm, T_B_C);
    if (!p_W) continue;
    for (std::size_t k = 1; k < map.keyframes.size(); ++k) {
      const Keyframe& kf = *map.keyframes[k];
      auto o = kf.observations.find(id);
      if (o == kf.observations.end()) continue;
      const Vec3 p_C = (kf.pose() * kf.cameraAt(o->second, T_B_C)).inverse() * *p_W;
      const double depth = o->second.bearing_C.dot(p_C);
      if (depth > options.landmark_min_depth_m)
        reanchor[id] = {kf.id, o->second.bearing_C, 1.0 / depth, o->second.row_s};
      break;
    }
  }
  // Landmarks that end here, strongest first (LiDAR-linked, then most observed), up to the
  // optional bound (each costs O(k^2) in the prior's Schur step, k = the states it touches).
  std::vector<std::pair<int, TrackId>> ending;
  std::unordered_set<TrackId> lidar_tracks;
  for (const auto& kf : map.keyframes)
    for (const auto& a : kf->lidar) lidar_tracks.insert(a.track_id);
  for (const auto& [id, lm] : map.landmarks)
    if (lm.anchor_kf == oldest->id && !reanchor.count(id))
      ending.emplace_back(-(map.observationCount(id) + (lidar_tracks.count(id) ? 100 : 0)), id);
  std::sort(ending.begin(), ending.end());
  std::unordered_set<TrackId>& marginalized = plan.marginalized;
  const std::size_t max_marginalized =
      options.marginalize_max_landmarks > 0
          ? static_cast<std::size_t>(options.marginalize_max_landmarks)
          : ending.size();
  for (std::size_t k = 0; k < ending.size() && k < max_marginalized; ++k)
    if (ending[k].first <= -2) marginalized.insert(ending[k].second);
  if (options.marginalize_reanchored == ReanchoredPrior::kLink)
    for (const auto& [id, r] : reanchor) marginalized.insert(id);
  return plan;
}

void reanchorLandmarks(WindowMap& map, int oldest_id, const MarginalizationPlan& plan) {
  for (auto it = map.landmarks.begin(); it != map.landmarks.end();) {
    Landmark& lm = it->second;
    if (lm.anchor_kf != oldest_id) {
      ++it;
      continue;
    }
    const auto r = plan.reanchor.find(it->first);
    if (r == plan.reanchor.end()) {
      it = map.landmarks.erase(it);
      continue;
    }
    lm.anchor_kf = r->second.kf_id;
    lm.bearing_anchor_C = r->second.bearing_C;
    lm.anchor_row_s = r->second.row_s;
    lm.rho[0] = r->second.rho;
    lm.on_ground = false;  // labelled again against the new anchor's plane
    ++it;
  }
}

}  // namespace ovo::estimator
