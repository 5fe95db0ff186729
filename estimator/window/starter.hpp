// Starting the window (DESIGN section 7): a two-view reference frame, and the attempt to
// initialise from it and a later frame: the two-view geometry (the gyro's rotation and a 2-point
// translation, else the 8-point), its metric scale (LiDAR range ratios, challenged by the ground
// plane) and when to put an ambiguous or missing scale off. Before that, each frame's rotation
// from the reference (without a gyro).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/common/ground_plane.hpp"
#include "estimator/common/two_view.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/ground_chain.hpp"
#include "estimator/window/lidar_ranges.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"
#include "estimator/window/scans.hpp"
#include "frontend/relative_pose.hpp"

namespace ovo::estimator {

/// The observations of a map in track-id order.
std::vector<TrackObservation> sortedObservations(
    const std::unordered_map<TrackId, TrackObservation>& m);

/// A two-view reference: a frame the window may start from and the tracks it keeps.
struct Reference {
  Timestamp t_ns = 0;
  SE3 T_W_B = SE3::Identity();
  std::unordered_map<TrackId, TrackObservation> obs;
  int frame_index = 0;  // its index in the frame log
  // Frames since the reference (record index, their sightings of the reference's tracks):
  // refined against the first landmarks once the window initialises.
  std::vector<std::pair<int, std::vector<TrackObservation>>> pending;
  /// Adds the frame's sightings of the reference's tracks to `pending` (none: nothing added).
  void keepSightings(int frame_record, const VisualFrame& frame);
  /// Forgets the sightings of the frames recorded before frame_record (settled for good).
  void forgetSightingsBefore(int frame_record);
  /// The bearings of the tracks the frame shares with the reference: b0 here, b1 in the frame
  /// (and their ids when asked for), in the frame's order.
  void sharedBearings(const VisualFrame& frame, std::vector<Vec3>* b0, std::vector<Vec3>* b1,
                      std::vector<TrackId>* ids = nullptr) const;
};

/// The geometry the window starts from: the reference and the frame at metric scale.
struct InitialGeometry {
  SE3 T_W_B1 = SE3::Identity();  // the frame's body pose
  double scale = 1.0;            // metres per unit baseline
  bool lidar_scale = false;      // the scale came from the LiDAR
  bool scale_known = true;       // false: neither the LiDAR nor the ground gave one (unit baseline)
  TwoViewResult two_view;        // at unit baseline; points_index indexes ids and b0
  std::vector<TrackId> ids;      // the tracks the frame shares with the reference
  std::vector<Vec3> b0;          // their bearings in the reference
};

class WindowStarter {
 public:
  enum class Outcome {
    kNotYet,            // keep the reference, try again with a later frame
    kRestartReference,  // the reference is used up: start a new one at this frame
    kReady,             // initialise from the geometry
  };
  /// The scan for a frame and its LiDAR pose (ScanTimeline::scanFor with the window's state).
  using ScanLookup = std::function<std::optional<FrameScan>(Timestamp, const SE3&)>;
  using Note = std::function<void(const std::string&)>;

  WindowStarter(const SensorSetup& setup, const WindowOptions& options,
                const GroundPlaneOptions& ground_options,
                const frontend::RelativePoseOptions& relpose_options, double inlier_rad,
                const WindowLidar& lidar, bool use_gyro, bool use_lidar, Note note);

  /// One attempt with the frame at the predicted pose T_W_B_pred (its rotation the gyro's, when
  /// there is one). can_reference: whether this frame may start a new reference (with the LiDAR:
  /// it has a scan).
  Outcome attempt(const Reference& ref, const VisualFrame& frame, const SE3& T_W_B_pred,
                  const ScanLookup& scan_for, const std::function<bool()>& can_reference,
                  InitialGeometry* out);
  /// Before initialisation without a gyro: the frame's rotation from the two-view 8-point to the
  /// reference, else to the ground chain's anchor, else T_W_B_pred's.
  Mat3 rotationFromReference(const Reference& ref, const VisualFrame& frame, const SE3& T_W_B_pred,
                             const GroundChain* chain) const;
  /// A standstill: waiting for a scale while still loses no motion, so the wait restarts.
  void standstill() { scale_wait_since_.reset(); }

 private:
  std::optional<InitialGeometry> twoView(const Reference& ref, const VisualFrame& frame,
                                         const SE3& T_W_B_pred, double min_parallax_deg) const;

  const SensorSetup& setup_;
  const WindowOptions& options_;
  GroundPlaneOptions ground_options_;
  double inlier_rad_;
  const WindowLidar& lidar_;
  bool use_gyro_, use_lidar_;
  Note note_;
  std::unique_ptr<frontend::RelativePoseEstimator> relpose_;  // without a gyro
  // Initialisations put off in a row for an ambiguous or missing scale; at the limit the ground
  // plane is used, and without a scale the reference restarts.
  static constexpr int kMaxScaleDeferrals = 20;
  int scale_deferrals_ = 0;
  // Since when no initialisation found a scale (with a scale sensor; a standstill restarts it):
  // references restart for up to kMaxScaleWaitS of motion before a unit baseline is accepted.
  static constexpr double kMaxScaleWaitS = 2.0;
  std::optional<Timestamp> scale_wait_since_;
};

}  // namespace ovo::estimator
