// The camera's height above the ground measured by a LiDAR pitched down (DESIGN section 7: the
// ground-plane scale needs the camera height; a rig without one can take it from the LiDAR). The
// beams that reach the ground end at one height in the body frame, the ground's (body z up, the
// ground normal); nothing else a planar scan sees is flat across the scan at one height below the
// LiDAR. The camera height is the body's height above that ground plus the camera's height in
// the body.
#pragma once

#include <deque>
#include <optional>
#include <vector>

#include "common/types.hpp"

namespace ovo::estimator {

struct LidarGroundOptions {
  int max_scans = 50;               // the first scans looked at (5 s of a 10 Hz LiDAR)
  double min_drop_m = 0.1;          // ground hits lie at least this far below the LiDAR (a level
                                    // LiDAR's end points all lie at its own height)
  double band_m = 0.04;             // width of the densest height band of the lower end points
  int min_points = 20;              // a scan's band needs this many end points ...
  double min_fraction = 0.05;       // ... and this fraction of its valid beams
  double max_below_fraction = 0.1;  // ... with at most this many end points (a fraction of the
                                    // band's) more than band_m below it
  int min_scans = 5;                // scans that agree needed for an answer ...
  double min_agreeing = 0.2;        // ... and this fraction of the scans with a band
  double agreement_m = 0.02;        // scans agree when their heights are within this of each other
  double roughness_gate_m = 0.15;   // groundRoughnessFromScan: end points this far from the band
                                    // start the line's fit (the gate then narrows to 4 spreads),
                                    // and this far below the line are a wall's
};

/// The body's height above the ground in one scan (T_B_L: LiDAR to body): minus the median body
/// z of the densest band_m of end points lying min_drop_m or more below the LiDAR; nullopt when
/// the band has too few points or too many lie below it.
std::optional<double> bodyHeightFromScan(const LidarScan& scan, const SE3& T_B_L,
                                         const LidarGroundOptions& options = {});

/// The ground's roughness across one scan: a pitched planar scan meets flat ground along a
/// straight line (across the body, a few metres ahead), so the spread of its ground end points'
/// body heights about the line z = a + b y fitted through them (b: the body's roll over the
/// ground) is the terrain's height spread there plus the range noise's share. Both are metric and
/// independent of any visual scale.
struct GroundRoughness {
  double spread_m = 0.0;  // robust standard deviation (1.4826 MAD) of the heights about the line
  double noise_m = 0.0;   // the range noise's share of it: range sigma times the median of the
                          // beams' |up component| (a beam that meets the ground at a grazing
                          // angle moves its end point little in height)
  int points = 0;         // ground end points about the line
};

/// The ground's roughness in one scan: the line fitted from the densest roughness_gate_m-wide band
/// of end points min_drop_m or more below the LiDAR, its gate narrowed to 4 spreads. nullopt with
/// fewer than options.min_points end points about it, when they do not lie across the body (their
/// lateral spread no larger than their spread ahead, or 3 of 8 parts of their lateral extent
/// empty: a wall's), or when more than max_below_fraction of them lie roughness_gate_m below it.
/// range_sigma_m: the LiDAR's range noise (rig.yaml's lidar.range_sigma_m).
std::optional<GroundRoughness> groundRoughnessFromScan(const LidarScan& scan, const SE3& T_B_L,
                                                       double range_sigma_m,
                                                       const LidarGroundOptions& options = {});

/// The terrain's height standard deviation from recent scans' roughness: the median spread less
/// the median range-noise share, in quadrature (0 where the noise explains it all); nullopt with
/// fewer than min_scans. On markedly rough ground it reads low: the scans whose ground hides behind
/// bumps give nothing, and those left are the smoother ones.
std::optional<double> terrainRoughness(const std::deque<GroundRoughness>& scans, int min_scans);

struct LidarCameraHeight {
  double camera_height_m = 0.0;  // the body's height plus the camera's height in the body
  int scans_agreeing = 0;        // scans in the largest group that agrees ...
  int scans_used = 0;            // ... of those with a ground band ...
  int scans_seen = 0;            // ... of those looked at
};

/// The body's height from the first max_scans scans (bodyHeightFromScan), plus T_B_C's z: the
/// median of the largest group of scans whose heights agree within agreement_m. While the robot
/// drives, the ground 5 m ahead where a pitched scan meets it is seldom in the plane the robot
/// stands on (on a rough slope the heights scatter widely); standing, or on flat ground, the
/// scans agree. nullopt when the group is smaller than min_scans or min_agreeing of the scans
/// with a band.
std::optional<LidarCameraHeight> cameraHeightFromLidar(const std::vector<LidarScan>& scans,
                                                       const SE3& T_B_L, const SE3& T_B_C,
                                                       const LidarGroundOptions& options = {});

}  // namespace ovo::estimator
