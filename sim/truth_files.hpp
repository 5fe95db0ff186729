// The simulator's truth about its sensors' timing, as text for the dataset's sim/ folder (beside
// sim/truth_bias.csv and sim/scenario.yaml): sim/truth_timing.yaml (the camera's time offset and
// readout, the LiDAR's beam times, the gyro's stamp jitter, the dropped frames) and
// sim/truth_frames.csv (each frame's true time, stamp, whether it was dropped, and its gains).
// Written only when one of those realities is on, so older scenarios write what they did.
#pragma once

#include <string>

#include "sim/scenario.hpp"

namespace ovo::sim {

class Simulation;

/// True when the scenario turns on a time offset, a rolling shutter, frame drops, auto-exposure,
/// a LiDAR sweep or gyro stamp jitter.
bool hasTimingRealities(const Scenario& scenario);

/// sim/truth_timing.yaml (io::readTrueTiming reads it).
std::string truthTimingYaml(const Simulation& simulation);

/// sim/truth_frames.csv: `#frame,t_true [ns],stamp [ns],dropped,light_gain,auto_exposure_gain`.
std::string truthFramesCsv(const Simulation& simulation);

}  // namespace ovo::sim
