// Planar LiDAR model: beams in the x-y plane of L (angle 0 along +x, increasing towards +y) cast
// into the same world the camera sees (leaf layers block a beam where their coverage reaches 0.5,
// so beams pass through canopy gaps), with Gaussian range noise, a maximum range and random
// dropouts. A scan is instantaneous at its stamp, or swept: beam i cast from the pose at
// stamp + i * time_increment (motion skew, as a turning mirror's beams are).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "common/types.hpp"
#include "sim/scenario.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"

namespace ovo::sim {

/// Number of beams of a scan: angle_min .. angle_max inclusive at angle_increment.
int lidarBeamCount(const LidarOptions& options);

/// One scan seen from T_W_L at time t_s (s from the sequence start); `noise_seed` draws the noise
/// of this scan (ignored when options.noise is false). No return: NaN.
LidarScan simulateScan(const VineyardWorld& world, const SE3& T_W_L, double t_s, Timestamp t_ns,
                       const LidarOptions& options, std::uint64_t noise_seed);

/// A swept scan: beam i is cast from T_W_L_at(t_s + i * time_increment_s) into the world at that
/// time; the scan is stamped t_ns (the first beam) and carries time_increment_s. The noise draws
/// are those of simulateScan for the same seed (time_increment_s = 0 gives simulateScan's scan).
LidarScan simulateSweptScan(const VineyardWorld& world, const std::function<SE3(double)>& T_W_L_at,
                            double t_s, Timestamp t_ns, double time_increment_s,
                            const LidarOptions& options, std::uint64_t noise_seed);

}  // namespace ovo::sim
