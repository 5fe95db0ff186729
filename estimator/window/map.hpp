// The sliding window's contents: keyframes (pose, gyro bias, terrain plane, observed tracks, LiDAR
// beams), the inverse-depth landmarks anchored in them, and the per-frame tracks that feed them.
// Parameter blocks are plain arrays at stable addresses (keyframes by unique_ptr, landmarks in a
// node map) so that Ceres problems and the marginalisation prior can refer to them across solves.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "common/types.hpp"
#include "factors/accel_factor.hpp"
#include "factors/gyro_preintegration.hpp"

namespace ovo::estimator {

using TrackId = std::int64_t;

/// One tracked feature in one frame: stable track id, full-resolution pixel and unit bearing in C.
struct TrackObservation {
  TrackId track_id = 0;
  Vec2 px = Vec2::Zero();
  Vec3 bearing_C = Vec3::UnitZ();
  int age = 1;  // frames the track has lived (selection prefers old tracks)
  /// The camera's pixels per radian at this bearing: d px / d (angles along
  /// factors::BearingFactor::tangentBasis(bearing_C)); zero when not known (a keyframe's
  /// observations get it).
  Mat2 px_per_rad = Mat2::Zero();
  /// When a rolling shutter exposed this sighting's row, s after the frame's time (its first
  /// row's); 0 with a global shutter. Set once as the frame enters the window (WindowModel::
  /// rowTime), so that every consumer places the camera at the same time (Keyframe::cameraAt).
  double row_s = 0.0;
};

/// What the frontend hands the window core for one camera frame.
struct VisualFrame {
  Timestamp t_ns = 0;
  std::vector<TrackObservation> observations;
  bool frontend_ok = true;       // false: the frontend failed on this frame (no usable tracks)
  double median_flow_px = -1.0;  // to the previous frame (< 0: unknown, computed from tracks)
};

/// The body's motion while a rolling shutter reads an image out: angular rate and velocity in the
/// body frame at the frame's time (its first row's).
struct Readout {
  Vec3 rate_B = Vec3::Zero();      // rad/s
  Vec3 velocity_B = Vec3::Zero();  // m/s
  /// The camera's pose in the body of the frame's time when the row of time row_s (s after the
  /// frame's time, TrackObservation::row_s) was exposed: the rig's T_B_C moved by this motion
  /// over row_s. The one model of where the camera was when a row was exposed: bearings,
  /// landmarks' points, LiDAR and terrain factors, re-anchoring, per-frame tracking and the
  /// outlier test all go through it.
  SE3 cameraAt(double row_s, const SE3& T_B_C) const;
};

/// A LiDAR beam associated with a landmark at a keyframe.
struct LidarAssociation {
  TrackId track_id = 0;
  double range_m = 0.0;
  bool planar = false;  // range interpolated at the landmark's azimuth: compare in the scan plane
  Vec3 ground_up_L = Vec3::Zero();  // non-zero: a ground beam's end; the landmark lies on the
                                    // ground plane up_L . p_L = range_m (lidar_ground_beams plane)
  double ground_sin = 0.0;  // ... the sine of the angle at which that beam meets the ground: its
                            // range noise moves the beam end off the plane by this fraction
};

/// A keyframe: its states (Ceres blocks) and what it observed. Made with the LiDAR's pose for
/// its scan (T_B_L below), so that no copy of a keyframe can leave it behind.
struct Keyframe {
  explicit Keyframe(const SE3& lidar_pose_B) : T_B_L(lidar_pose_B) {}

  int id = 0;  // increasing over the run
  Timestamp t_ns = 0;
  double q_W_B[4] = {0, 0, 0, 1};  // x, y, z, w
  /// The gyro chain's orientation of the keyframe, tied to q_W_B by WindowModel::
  /// vision_rotation_sigma_rad (its gyro factors use this one; unused when that is 0).
  double q_W_G[4] = {0, 0, 0, 1};
  double p_W_B[3] = {0, 0, 0};
  double b_g[3] = {0, 0, 0};
  /// The terrain under the keyframe, z = a x + b y + c in W (factors/terrain_plane_factor.hpp);
  /// seeded by seedTerrain (terrain_set) before its first solve.
  double terrain[3] = {0, 0, 0};
  bool terrain_set = false;
  /// The camera's height over the ground it sees here less the rig's, m (WindowModel::
  /// camera_height_path_sigma_m; stays 0 without it).
  double height_offset_m[1] = {0.0};
  std::unordered_map<TrackId, TrackObservation> observations;
  /// Gyro preintegration from the previous keyframe of the same segment (null: none / no gyro).
  std::shared_ptr<factors::GyroPreintegration> preint_from_prev;
  /// The accelerometer over the same interval (WindowModel::accel_sigma_mps2; none without it or
  /// where the samples do not cover the interval).
  std::optional<factors::AccelInterval> accel_from_prev;
  std::vector<LidarAssociation> lidar;             // beams associated with landmarks
  std::vector<LidarAssociation> lidar_candidates;  // beams near tracks (landmarks or not yet)
  std::unordered_set<TrackId> lidar_rejected;      // associations removed as outliers: not again
  std::optional<LidarScan> scan;
  /// The LiDAR's pose when it took `scan`, in this keyframe's body frame: the rig's T_B_L for a
  /// scan at the keyframe's time, moved by the motion in between for an earlier one (the rig's
  /// T_B_L without a scan).
  SE3 T_B_L;
  int segment = 0;  // increases at every re-initialisation after a tracking loss
  /// Zero-rate update from a standstill after this keyframe: the bias measured as the mean gyro
  /// rate of the still frames (a bias prior factor while the keyframe is in the window).
  struct ZeroRate {
    Vec3 bias_radps = Vec3::Zero();
    double sigma_radps = 1.0;  // per axis
  };
  std::optional<ZeroRate> zero_rate;
  /// The body's motion while a rolling shutter reads the image out (the keyframe's pose is its
  /// first row's; zero with a global shutter).
  Readout readout;

  SE3 pose() const;  // as the vision sees it: q_W_B, p_W_B
  /// The camera's pose in this keyframe's body row_s after its time (Readout::cameraAt).
  SE3 cameraAt(double row_s, const SE3& T_B_C) const { return readout.cameraAt(row_s, T_B_C); }
  /// The same at a sighting's row (o.row_s).
  SE3 cameraAt(const TrackObservation& o, const SE3& T_B_C) const {
    return cameraAt(o.row_s, T_B_C);
  }
  SE3 bodyPose() const;            // the body's estimate: q_W_G, p_W_B (the output)
  void setPose(const SE3& T_W_B);  // sets q_W_G to the same orientation
  /// Copies the states (q_W_B, q_W_G, p_W_B, b_g, terrain, height_offset_m) of another keyframe,
  /// e.g. a batch copy's.
  void copyStates(const Keyframe& from);
  Vec3 bias() const { return Vec3(b_g[0], b_g[1], b_g[2]); }
  void setBias(const Vec3& b);
};

/// A landmark: inverse depth rho along the unit bearing of its anchor keyframe's observation.
struct Landmark {
  TrackId id = 0;
  int anchor_kf = -1;  // Keyframe::id
  Vec3 bearing_anchor_C = Vec3::UnitZ();
  /// The anchor sighting's row time (TrackObservation::row_s): the anchor camera is
  /// anchor.cameraAt(anchor_row_s, T_B_C), in every factor and in pointW.
  double anchor_row_s = 0.0;
  double rho[1] = {0.1};              // 1/m
  bool on_ground = false;             // has a camera-height factor (labelled by the plane fit)
  Vec3 ground_up_C = -Vec3::UnitY();  // ground normal in the anchor camera frame (unit, up)
};

/// The world point of landmark lm anchored in `anchor` (from its anchor camera at the anchor
/// sighting's row), or nullopt when rho is not positive or the point is not finite.
std::optional<Vec3> landmarkPointW(const Keyframe& anchor, const Landmark& lm, const SE3& T_B_C);

/// The window: keyframes oldest first, landmarks by track id, and (for the offline full
/// refinement) every keyframe that left the window.
class WindowMap {
 public:
  std::deque<std::unique_ptr<Keyframe>> keyframes;
  std::unordered_map<TrackId, Landmark> landmarks;
  std::vector<std::unique_ptr<Keyframe>> archive;  // marginalised keyframes (refine full only)
  std::unordered_map<TrackId, Vec3> last_point_W;  // last estimate of every landmark (refine)
  /// The camera-gyro time offset on top of the rig's, s (image stamp minus the gyro clock's time
  /// of the image): one state for the whole run, in the marginalisation prior once a gyro factor
  /// has left the window. The window's gyro intervals are [t - this, t' - this].
  double time_offset_s[1] = {0.0};
  /// The correction of the rig's camera height the camera-height factors use, m: one state for
  /// the whole run, seen through the LiDAR's ranges and ground beams.
  double camera_height_offset_m[1] = {0.0};
  /// Gravity's direction in W and the accelerometer's bias (factors::kGravityStateSize; with
  /// WindowModel::accel_sigma_mps2): one state for the whole run, set from the first
  /// accelerometer interval (gravity_set) and then estimated.
  double gravity[factors::kGravityStateSize] = {0.0, 0.0, 0.0, 0.0, 0.0};
  bool gravity_set = false;

  Keyframe* find(int kf_id);
  const Keyframe* find(int kf_id) const;
  Keyframe& newest() { return *keyframes.back(); }
  bool empty() const { return keyframes.empty(); }

  /// World point of a landmark (from its anchor camera at the anchor sighting's row), or nullopt
  /// when its anchor is gone or rho is not positive.
  std::optional<Vec3> pointW(const Landmark& lm, const SE3& T_B_C) const;
  /// The same for the landmark of a track; nullopt also when the track has no landmark.
  std::optional<Vec3> pointW(TrackId id, const SE3& T_B_C) const;
  /// Number of keyframes in the window that observe the track.
  int observationCount(TrackId id) const;
  /// Remembers the current world points of all landmarks (for the refinement's initial values).
  void rememberPoints(const SE3& T_B_C);
};

/// Re-propagates the gyro preintegrations (keyframes in time order) whose bias linearisation is
/// now more than 0.002 rad/s from the previous keyframe's estimate.
void repropagateGyro(const std::vector<Keyframe*>& keyframes);

/// The keyframes by id.
std::unordered_map<int, Keyframe*> keyframesById(const std::vector<Keyframe*>& keyframes);

}  // namespace ovo::estimator
