// Keyframe policy of the window (DESIGN section 7): when a frame becomes a keyframe
// (rotation-compensated parallax, track loss, interval; frames with a scan preferred) and which of
// its tracks it keeps (spread over the image, tracks next to LiDAR beams first).
#pragma once

#include <unordered_set>
#include <vector>

#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// Tracks for a keyframe: every one in `keep`, then up to max_lidar_features of `priority`, then
/// the oldest tracks with at most features_per_cell per feature_cell_px cell, up to max_features
/// in all.
std::vector<TrackObservation> selectSpread(const std::vector<TrackObservation>& all,
                                           const std::unordered_set<TrackId>& keep,
                                           const std::unordered_set<TrackId>& priority,
                                           const WindowOptions& options);

/// What the keyframe decision knows of a frame besides its tracks.
struct KeyframeContext {
  bool has_scan = false;             // a scan at the frame's time
  bool scan_expected_after = false;  // the next frame is expected to bring a scan
};

/// Whether the frame at body pose T_W_B becomes a keyframe after `last`: fewer than 8 tracks
/// shared, a median rotation-compensated parallax of kf_parallax_deg (kf_parallax_scan_fraction
/// of it with a scan), fewer than kf_track_fraction of last's tracks alive, or kf_max_interval_s.
/// A frame without a scan whose successor is expected to bring one tolerates more track loss
/// (kf_track_fraction_between_scans): keyframes triggered by track loss alone would otherwise lock
/// onto the frames between scans when the LiDAR runs at a fraction of the camera rate.
bool isKeyframe(const VisualFrame& frame, const SE3& T_W_B, const Keyframe& last, const SE3& T_B_C,
                const KeyframeContext& context, const WindowOptions& options);

}  // namespace ovo::estimator
