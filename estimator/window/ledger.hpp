// The window's measurements by kind and key, and the ledger of where each one went when it left
// the window (into the marginalisation prior, or dropped), so that none is counted twice.
#pragma once

#include <compare>
#include <map>
#include <optional>
#include <utility>

#include "common/types.hpp"
#include "estimator/window/map.hpp"  // TrackId

namespace ovo::estimator {

enum class FactorKind {
  kBearing,          // a sighting of a landmark (anchor-relative or a step from the previous one)
  kGyro,             // preintegrated gyro rotation from the previous keyframe
  kBiasWalk,         // gyro bias random walk from the previous keyframe
  kBiasPrior,        // the gauge keyframe's bias prior
  kZeroRate,         // a standstill's zero-rate update on a keyframe's bias
  kPosePrior,        // the gauge keyframe's pose prior
  kLidar,            // a LiDAR range (or ground-plane height) to a landmark
  kMarginal,         // the marginalisation prior
  kGround,           // a ground landmark's height below its anchor camera
  kTerrain,          // a ground landmark on its anchor's terrain plane (track) or the plane's walk
  kRotationTie,      // a keyframe's vision orientation tied to its gyro chain's
  kTimeOffsetPrior,  // the camera-gyro time offset's prior (stays in the window)
  kCameraHeightPrior,  // the camera height correction's prior (the run's: stays in the window;
                       // along the path: on a segment's first keyframe, kf_id)
  kCameraHeightWalk,   // the path's camera height correction from the previous keyframe
  kAccel,              // the accelerometer between three keyframes (kf_id: the middle one)
  kAccelBiasPrior      // the accelerometer bias's prior (stays in the window)
};

/// The measurement a factor stands for: its kind, its landmark (-1: none) and its keyframe (the
/// observing keyframe of a sighting or range, the anchor of a ground or terrain point, the later
/// keyframe of a gyro, bias walk or terrain walk factor). The marginalisation prior has none.
struct FactorKey {
  FactorKind kind = FactorKind::kBearing;
  TrackId track = -1;
  int kf_id = -1;
  auto operator<=>(const FactorKey&) const = default;
};

/// Where each measurement that left the window went: into the marginalisation prior, or dropped
/// (its landmark or keyframe gone without it). A measurement is in the window, in the prior or
/// dropped, never two of these: buildFactors skips what the ledger holds. Entries of keyframes
/// that have left the window are forgotten (no factor can be built for them again).
class FactorLedger {
 public:
  enum class Fate { kPrior, kDropped };
  /// Records a measurement's fate; false when it had one already (a measurement counted twice).
  bool record(const FactorKey& key, Fate fate);
  std::optional<Fate> fate(const FactorKey& key) const;
  /// Forgets the entries of keyframes with an id below oldest_kf_id.
  void forgetBefore(int oldest_kf_id);
  std::size_t size() const { return fates_.size(); }
  const std::map<FactorKey, Fate>& entries() const { return fates_; }
  /// Over the ledger's life (forgetting keeps them): measurements of a kind given a fate, and
  /// records refused because the measurement had a fate already.
  int recorded(FactorKind kind, Fate fate) const;
  int refused() const { return refused_; }

 private:
  std::map<FactorKey, Fate> fates_;
  std::map<std::pair<FactorKind, Fate>, int> recorded_;
  int refused_ = 0;
};

}  // namespace ovo::estimator
