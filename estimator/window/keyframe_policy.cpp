// When a frame becomes a keyframe, and which of its tracks it keeps.
#include "estimator/window/keyframe_policy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "common/stats.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

std::vector<TrackObservation> selectSpread(const std::vector<TrackObservation>& all,
                                           const std::unordered_set<TrackId>& keep,
                                           const std::unordered_set<TrackId>& priority,
                                           const WindowOptions& o) {
  std::vector<TrackObservation> out;
  std::vector<const TrackObservation*> prio, rest;
  for (const auto& ob : all) {
    if (keep.count(ob.track_id))
      out.push_back(ob);
    else if (priority.count(ob.track_id))
      prio.push_back(&ob);
    else
      rest.push_back(&ob);
  }
  std::unordered_map<std::int64_t, int> cells;
  auto cellOf = [&o](const Vec2& px) {
    return (static_cast<std::int64_t>(std::floor(px.x() / o.feature_cell_px)) << 32) +
           static_cast<std::int64_t>(std::floor(px.y() / o.feature_cell_px));
  };
  for (const auto& ob : out) ++cells[cellOf(ob.px)];
  int n_prio = 0;
  for (const TrackObservation* ob : prio) {
    if (n_prio++ >= o.max_lidar_features || static_cast<int>(out.size()) >= o.max_features) break;
    out.push_back(*ob);
  }
  std::stable_sort(
      rest.begin(), rest.end(),
      [](const TrackObservation* a, const TrackObservation* b) { return a->age > b->age; });
  for (const TrackObservation* ob : rest) {
    if (static_cast<int>(out.size()) >= o.max_features) break;
    int& c = cells[cellOf(ob->px)];
    if (c >= o.features_per_cell) continue;
    ++c;
    out.push_back(*ob);
  }
  return out;
}

bool isKeyframe(const VisualFrame& frame, const SE3& T_W_B, const Keyframe& last, const SE3& T_B_C,
                const KeyframeContext& context, const WindowOptions& options) {
  const bool has_scan = context.has_scan;
  const Mat3 R_Ck_C = T_B_C.linear().transpose() * last.pose().linear().transpose() *
                      T_W_B.linear() * T_B_C.linear();
  std::vector<double> angles;
  for (const auto& o : frame.observations) {
    auto it = last.observations.find(o.track_id);
    if (it == last.observations.end()) continue;
    angles.push_back(
        std::acos(std::clamp((R_Ck_C * o.bearing_C).dot(it->second.bearing_C), -1.0, 1.0)));
  }
  const double parallax_deg = upperMedian(angles) / kDegToRad;
  const double alive = last.observations.empty()
                           ? 0.0
                           : static_cast<double>(angles.size()) / last.observations.size();
  const double threshold =
      options.kf_parallax_deg * (has_scan ? options.kf_parallax_scan_fraction : 1.0);
  const double min_alive =
      !has_scan && context.scan_expected_after
          ? std::min(options.kf_track_fraction_between_scans, options.kf_track_fraction)
          : options.kf_track_fraction;
  return angles.size() < 8 || parallax_deg >= threshold || alive < min_alive ||
         toSeconds(frame.t_ns - last.t_ns) >= options.kf_max_interval_s;
}

}  // namespace ovo::estimator
