#include "sim/truth_files.hpp"

#include <fmt/format.h>

#include "sim/lidar.hpp"
#include "sim/simulation.hpp"

namespace ovo::sim {

bool hasTimingRealities(const Scenario& s) {
  return s.camera.time_offset_s != 0.0 || s.camera.rolling_shutter_s > 0.0 ||
         s.camera.frame_drop_probability > 0.0 || s.camera.auto_exposure || s.lidar.sweep ||
         s.imu.time_jitter_s > 0.0;
}

std::string truthTimingYaml(const Simulation& sim) {
  const Scenario& s = sim.scenario();
  int dropped = 0;
  for (int k = 0; k < sim.frameCount(); ++k) dropped += sim.frameDropped(k) ? 1 : 0;
  const double dt_beam = s.lidar.timeIncrementS();
  const double turn = s.lidar.sweep ? dt_beam * 360.0 / s.lidar.angle_increment_deg : 0.0;
  std::string y = "# Simulator truth of the sensors' timing (ovo simulate). Seconds.\n";
  y += fmt::format(
      "camera:\n"
      "  time_offset_s: {}       # image stamp = true (gyro-clock) time + this\n"
      "  rolling_shutter_s: {}   # row v of H read out at the frame's true time + v / H * this\n"
      "  frames: {}\n"
      "  frames_dropped: {}\n",
      s.camera.time_offset_s, s.camera.rolling_shutter_s, sim.frameCount(), dropped);
  y += fmt::format(
      "lidar:\n"
      "  time_increment_s: {}    # beam i at the scan's stamp + i * this (0: instantaneous)\n"
      "  scan_time_s: {}         # one turn of the mirror (0: instantaneous)\n"
      "  beams: {}\n",
      dt_beam, turn, lidarBeamCount(s.lidar));
  y += fmt::format(
      "imu:\n"
      "  time_jitter_s: {}       # std of the stamps around the samples' true times\n",
      s.imu.time_jitter_s);
  return y;
}

std::string truthFramesCsv(const Simulation& sim) {
  std::string out = "#frame,t_true [ns],stamp [ns],dropped,light_gain,auto_exposure_gain\n";
  for (int k = 0; k < sim.frameCount(); ++k)
    out += fmt::format("{},{},{},{},{},{}\n", k, sim.frameTrueStamp(k), sim.frameStamp(k),
                       sim.frameDropped(k) ? 1 : 0, sim.exposureGain(sim.frameTime(k)),
                       sim.autoExposureGain(k));
  return out;
}

}  // namespace ovo::sim
