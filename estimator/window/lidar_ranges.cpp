// Keyframes' LiDAR ranges to landmarks, their scale ratio, and the start's scale vote.
#include "estimator/window/lidar_ranges.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "common/stats.hpp"
#include "estimator/common/lidar_scale.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

std::vector<LidarAssociation> WindowLidar::candidates(
    const std::vector<TrackObservation>& observations, const std::optional<FrameScan>& scan) const {
  std::vector<LidarAssociation> out;
  if (!scan) return out;
  for (const BeamMatch& m :
       associateBeams(usableBeams(*scan), observations, options_.lidar_radius_px))
    out.push_back({m.track_id, m.range_m});
  return out;
}

std::vector<BeamInImage> WindowLidar::usableBeams(const FrameScan& scan) const {
  return projectScan(*scan.scan, setup_.camera, cameraFromLidar(setup_.T_B_C, scan.T_B_L),
                     options_.lidar_edge_step, options_.lidar_edge_neighbours);
}

std::vector<LidarRange> WindowLidar::rangesAt(const Keyframe& kf, const WindowMap& map,
                                              double scale, const PointsW* points_W) const {
  const auto pointOf = [&](TrackId id) -> std::optional<Vec3> {
    if (points_W == nullptr) return map.pointW(id, setup_.T_B_C);
    const auto it = points_W->find(id);
    if (it == points_W->end()) return std::nullopt;
    return it->second;
  };
  std::vector<LidarRange> out;
  const SE3 T_L_W = (kf.pose() * kf.T_B_L).inverse();
  // At another scale: each point scaled about the keyframe's camera, as a rescale by `scale`
  // would put it as the keyframe sees it.
  const SE3 T_C_W = (kf.pose() * setup_.T_B_C).inverse();
  const SE3 T_C_L = cameraFromLidar(setup_.T_B_C, kf.T_B_L);
  const SE3 T_L_C = T_C_L.inverse();
  const auto inLidar = [&](const Vec3& p_W) -> Vec3 {
    return scale == 1.0 ? Vec3(T_L_W * p_W) : Vec3(T_L_C * (scale * (T_C_W * p_W)));
  };
  if (options_.lidar_interpolate) {
    // Every landmark the keyframe sees whose point lies within a small elevation of the scan
    // plane: the scan's range interpolated at its azimuth (no pixel-radius offset along the scan).
    if (!kf.scan) return out;
    const double max_tan_elevation = std::tan(options_.lidar_max_elevation_deg * kDegToRad);
    // Ground beams (isGroundBeam) are told apart unless lidar_ground_beams is raw.
    const double ground_height =
        options_.lidar_ground_beams != GroundBeams::kRaw && setup_.camera_height_m
            ? *setup_.camera_height_m
            : 0.0;
    const bool skip_ground = options_.lidar_ground_beams == GroundBeams::kSkip;
    const Vec3 up_C = bodyUpIn(setup_.T_B_C);
    const Vec3 up_L = bodyUpIn(kf.T_B_L);
    for (const auto& [id, o] : kf.observations) {
      const auto p_W = pointOf(id);
      if (!p_W) continue;
      const Vec3 p_L = inLidar(*p_W);
      const double d_xy = p_L.head<2>().norm();
      if (!(d_xy > 1e-3) || std::abs(p_L.z()) > max_tan_elevation * d_xy) continue;
      const double phi = std::atan2(p_L.y(), p_L.x());
      const auto r =
          interpolateRange(*kf.scan, phi, options_.lidar_edge_step, options_.lidar_edge_neighbours);
      if (!r) continue;
      LidarRange range{{id, *r, true}, d_xy, *r, false};
      const Vec3 hit_L(*r * std::cos(phi), *r * std::sin(phi), 0.0);
      if (isGroundBeam(T_C_L * hit_L, up_C, ground_height)) {
        if (skip_ground) continue;
        // plane: the landmark on the ground plane through the beam end; its distance for the
        // gate where the observed ray meets that plane.
        const auto d =
            groundRangeAlongRay(hit_L, up_L, T_L_C.translation(), T_L_C.rotation() * o.bearing_C);
        if (!d) continue;
        range = {
            {id, up_L.dot(hit_L), false, up_L, groundIncidenceSine(hit_L, up_L)}, d_xy, *d, true};
      }
      out.push_back(range);
    }
    return out;
  }
  for (const LidarAssociation& c : kf.lidar_candidates) {
    const auto p_W = pointOf(c.track_id);
    if (!p_W) continue;
    out.push_back({c, inLidar(*p_W).norm(), c.range_m, false});
  }
  return out;
}

void WindowLidar::associate(Keyframe& kf, const WindowMap& map, bool gate_depth) const {
  std::unordered_set<TrackId> have;
  for (const auto& a : kf.lidar) have.insert(a.track_id);
  for (const LidarRange& r : rangesAt(kf, map)) {
    const TrackId id = r.association.track_id;
    if (have.count(id) || kf.lidar_rejected.count(id)) continue;
    if (gate_depth &&
        std::abs(r.landmark_m - r.measured_m) > options_.lidar_depth_gate * r.measured_m)
      continue;
    kf.lidar.push_back(r.association);
  }
}

std::vector<std::pair<double, TrackId>> WindowLidar::rangeRatios(const WindowMap& map,
                                                                 double scale,
                                                                 const PointsW* points_W) const {
  // Ground beams are left out (their range hangs on the plane's elevation, not on the scale
  // alone).
  std::vector<std::pair<double, TrackId>> ratios;
  for (const auto& kf : map.keyframes)
    for (const LidarRange& r : rangesAt(*kf, map, scale, points_W))
      if (!r.ground && r.measured_m > 0.0)
        ratios.emplace_back(r.landmark_m / r.measured_m, r.association.track_id);
  return ratios;
}

std::optional<double> WindowLidar::agreedRatio(
    const std::vector<std::pair<double, TrackId>>& ratios) const {
  if (static_cast<int>(ratios.size()) < options_.lidar_rescale_min_ranges) return std::nullopt;
  std::vector<double> values;
  for (const auto& [ratio, id] : ratios) values.push_back(ratio);
  const double mid = upperMedian(values);
  // The ranges that agree with the median: at least half of them and min_ranges, from more than
  // one landmark (one landmark seen from every keyframe is one measurement, not a consensus).
  std::vector<double> agree;
  std::unordered_set<TrackId> tracks;
  for (const auto& [ratio, id] : ratios)
    if (std::abs(ratio / mid - 1.0) <= options_.lidar_rescale_agreement) {
      agree.push_back(ratio);
      tracks.insert(id);
    }
  if (static_cast<int>(agree.size()) < options_.lidar_rescale_min_ranges ||
      2 * agree.size() < ratios.size() || tracks.size() < 3)
    return std::nullopt;
  return upperMedian(agree);
}

std::optional<double> WindowLidar::scaleRatio(const WindowMap& map, bool* searched) const {
  if (searched) *searched = false;
  // Every range the window's keyframes measure to a landmark they see, gated or rejected or not:
  // the gates are what a wrong scale defeats.
  const auto ratios = rangeRatios(map, 1.0);
  if (const auto agreed = agreedRatio(ratios)) return agreed;
  if (!options_.lidar_interpolate) return std::nullopt;
  // No agreement at the window's scale. The ranges are read where the landmarks' points cross
  // the scan plane, so at a wrong scale they are the ranges of the wrong landmarks (those the
  // plane crosses at that scale) and disagree among themselves: the disagreement does not show
  // as one ratio. Look for the scale at which the scan agrees with the map: the one at which the
  // most ranges (from at least three landmarks) meet their landmarks within half the agreement,
  // when that is at least lidar_rescale_min_ranges and twice as many as at the window's own.
  const double half = 0.5 * options_.lidar_rescale_agreement;
  const auto support = [&](const std::vector<std::pair<double, TrackId>>& rs) {
    std::unordered_set<TrackId> tracks;
    int n = 0;
    for (const auto& [ratio, id] : rs)
      if (std::abs(ratio - 1.0) <= half) {
        ++n;
        tracks.insert(id);
      }
    return tracks.size() < 3 ? 0 : n;
  };
  const int at_one = support(ratios);
  // The landmarks' points once for every trial scale (each trial only scales them).
  PointsW points_W;
  for (const auto& [id, lm] : map.landmarks)
    if (const auto p = map.pointW(lm, setup_.T_B_C)) points_W.emplace(id, *p);
  constexpr double kStep = 0.04;  // log-scale step, below the half-agreement band
  constexpr int kSteps = 35;      // scales from 0.25 to 4
  int best = 0;
  double best_scale = 1.0;
  for (int k = -kSteps; k <= kSteps; ++k) {
    const double s = std::exp(kStep * k);
    if (std::abs(s - 1.0) <= options_.lidar_rescale_ratio) continue;
    const int n = support(rangeRatios(map, s, &points_W));
    if (n > best) best = n, best_scale = s;
  }
  if (best < options_.lidar_rescale_min_ranges || best < 2 * at_one) return std::nullopt;
  // At that scale the ranges must pass the test the window's own scale failed.
  const auto agreed = agreedRatio(rangeRatios(map, best_scale, &points_W));
  if (!agreed || std::abs(*agreed - 1.0) > half) return std::nullopt;
  // In the window's units: a landmark's distance there is its distance at best_scale over it.
  if (searched) *searched = true;
  return *agreed / best_scale;
}

LidarScaleVote voteLidarScale(std::vector<double> ratios, std::optional<double> ground_scale,
                              int min_associations, bool can_put_off) {
  using Outcome = LidarScaleVote::Outcome;
  LidarScaleVote vote;
  std::sort(ratios.begin(), ratios.end());
  // group_end[i]: one past the last ratio within 20 % of ratios[i].
  std::vector<std::size_t> group_end(ratios.size());
  for (std::size_t i = 0, j = 0; i < ratios.size(); ++i) {
    while (j < ratios.size() && ratios[j] <= ratios[i] * 1.2) ++j;
    group_end[i] = j;
  }
  const auto size = [&](std::size_t i) { return group_end[i] - i; };
  const auto median = [&](std::size_t i) { return ratios[i + size(i) / 2]; };
  const auto agreesWithGround = [&](double ratio) {
    return ground_scale && ratio <= 1.2 * *ground_scale && *ground_scale <= 1.2 * ratio;
  };
  std::size_t best_lo = 0, best_n = 0;
  for (std::size_t i = 0; i < ratios.size(); ++i)
    if (size(i) > best_n) best_n = size(i), best_lo = i;
  if (best_n == 0) return vote;
  std::size_t second_n = 0;
  for (std::size_t i = 0; i < ratios.size(); ++i)
    if (group_end[i] <= best_lo || i >= best_lo + best_n) second_n = std::max(second_n, size(i));
  const auto bigEnough = [&](std::size_t n) { return static_cast<int>(n) >= min_associations / 2; };
  // The largest group the ground plane agrees with, of at least half the largest's size or
  // min_associations / 2.
  std::size_t ground_lo = 0, ground_n = 0;
  for (std::size_t i = 0; i < ratios.size(); ++i)
    if ((2 * size(i) >= best_n || bigEnough(size(i))) && size(i) > ground_n &&
        agreesWithGround(median(i)))
      ground_n = size(i), ground_lo = i;
  const bool enough = bigEnough(best_n) && static_cast<int>(ratios.size()) >= min_associations &&
                      best_n >= ratios.size() / 3;
  const bool ground_disagrees = ground_scale && !agreesWithGround(median(best_lo));
  const bool tie = 2 * second_n >= best_n ||
                   (ground_disagrees && (enough || (ground_n > 0 && bigEnough(ground_n))));
  if (!tie) {
    if (enough) {
      vote.outcome = Outcome::kAgreed;
      vote.scale = median(best_lo);
    }
    return vote;
  }
  if (ground_n > 0) {
    vote.outcome = Outcome::kGroundSettled;
    vote.scale = median(ground_lo);
    return vote;
  }
  if (can_put_off) {
    vote.outcome = Outcome::kPutOff;
    return vote;
  }
  if (ground_scale) {
    vote.outcome = Outcome::kOverruled;
    return vote;
  }
  for (std::size_t i = 0; i < ratios.size(); ++i)
    if (2 * size(i) >= best_n) {
      vote.scale = median(i);
      break;
    }
  vote.outcome = Outcome::kForced;
  return vote;
}

}  // namespace ovo::estimator
