// Standstills of the window estimator: the test that a frame is still (the tracks' flow below a
// pixel threshold and a quiet gyro), and the zero-rate update, whose mean gyro rate over the still
// frames measures the gyro bias.
#pragma once

#include <deque>
#include <optional>
#include <vector>

#include "common/types.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// What the standstill test knows of a frame.
struct StillEvidence {
  bool has_observations = false;
  double flow_px = 1e9;            // median flow of the tracks to the previous frame, px
  double rate_radps = 0.0;         // bias-corrected mean gyro rate over the frame's interval
  int gyro_samples = 0;            // gyro samples in the interval
  double gyro_spread_radps = 0.0;  // their RMS deviation from their mean per axis (GyroScatter)
};

/// Still: some tracks, flow below standstill_flow_px and a quiet gyro. Quiet: the frame's samples
/// (at least 3) scatter no more than standstill_gyro_std_radps (no vibration, no turning) and,
/// once initialised (the bias known), their bias-corrected rate is below standstill_gyro_radps
/// (no slow steady turn); with fewer samples the rate test alone. Before initialisation the mean
/// rate is mostly bias (EuRoC's gyro: 0.08 rad/s): a robot standing still at the start would
/// never count as still, and its bias would never be measured.
bool isStill(const StillEvidence& e, bool use_gyro, bool initialized, const WindowOptions& options);

/// The median flow (px) of the tracks seen in both `obs` and `last_obs`; nullopt for fewer
/// than 10.
std::optional<double> medianFlowPx(const std::unordered_map<TrackId, TrackObservation>& obs,
                                   const std::unordered_map<TrackId, TrackObservation>& last_obs);

/// A zero-rate update on a keyframe (a bias prior factor while it is in the window); merged with
/// one it has already (a second standstill before the next keyframe) by information.
void addZeroRate(Keyframe& kf, const Vec3& bias_radps, double sigma_radps);

/// Zero-rate update of the gyro bias (DESIGN section 7): the mean raw gyro rate over still frames
/// without the last trim_s of each still streak (the frames just before the motion was detected,
/// which already hold the start of it), with sigma = noise_density / sqrt(T) plus the walk over
/// T, scaled up by sqrt(chi^2 / dof) when the frames scatter more than that noise explains.
class StandstillBias {
 public:
  struct Estimate {
    Vec3 bias_radps = Vec3::Zero();
    double time_s = 0.0;       // still time used, s
    double sigma_radps = 0.0;  // per axis
    double chi2_dof = 0.0;     // scatter of the frames' rates over the gyro noise (about 1: still)
  };
  StandstillBias(double noise_density, double bias_random_walk, double trim_s)
      : noise_density_(noise_density), bias_random_walk_(bias_random_walk), trim_s_(trim_s) {}

  /// One still frame: the raw (zero-bias) gyro rotation vector over dt_s, ending at t_ns.
  void add(Timestamp t_ns, const Vec3& rotation_rad, double dt_s);
  /// The first moving frame after still ones: the open streak loses its last trim_s and counts.
  void endStreak();
  bool inStreak() const { return open_frames_ > 0; }
  /// Over the ended streaks and the open one (untrimmed); nullopt below min_time_s.
  std::optional<Estimate> estimate(double min_time_s) const;
  void reset();
  /// Frames held one by one (the open streak's last trim_s): bounded however long the robot
  /// stands; the rest is kept as sums.
  std::size_t framesHeld() const { return recent_.size(); }

 private:
  struct Sample {
    Timestamp t_ns;
    Vec3 rotation_rad;
    double dt_s;
  };
  // Sums over frames in time order (the rotation and time added one frame at a time, so that the
  // estimate does not depend on how many frames are held one by one).
  struct Sums {
    Vec3 rotation_rad = Vec3::Zero();
    double time_s = 0.0;
    double rotation2_over_dt = 0.0;  // sum of |rotation|^2 / dt, rad^2/s
    int frames = 0;
    void add(const Sample& s);
  };
  double noise_density_;     // rad/s/sqrt(Hz)
  double bias_random_walk_;  // rad/s^2/sqrt(Hz)
  double trim_s_;            // s
  Sums counted_;  // the ended streaks' frames and the open streak's older than its last trim_s
  std::deque<Sample> recent_;  // the open streak's frames that its end may still trim
  int open_frames_ = 0;        // frames of the open streak (counted or recent)
};

}  // namespace ovo::estimator
