// The window's positions before it initialises, with a camera height: each frame measured from a
// recent anchor frame over a short baseline and scaled by the ground plane (the `vo` estimator's
// monocular scale), chained. The two-view reference the window starts from needs a long
// baseline, and on fast forward motion (KITTI) its tracks run out first: without the chain the
// frames before the start and each restarted reference lose the distance driven. (The frames from
// the reference the window starts at are posed again by the initialisation; with a LiDAR that is
// all of them unless the reference restarted.)
#pragma once

#include <optional>
#include <unordered_map>
#include <vector>

#include "common/types.hpp"
#include "estimator/common/ground_plane.hpp"
#include "estimator/common/two_view.hpp"
#include "estimator/window/map.hpp"

namespace ovo::estimator {

struct GroundChainOptions {
  // The window passes its landmark_min_parallax_deg for both angles.
  double min_parallax_deg = 1.0;  // median rotation-compensated parallax to measure a step, deg
  double min_point_parallax_deg = 1.0;  // a point's triangulation angle to count for the plane
  int max_frames = 6;                   // ... else measured anyway after this many frames
  int cell_px = 40;                     // anchor tracks thinned to per_cell per cell_px square
  int per_cell = 3;
  double max_speed_mps = 40.0;  // a ground scale implying more is rejected
};

class GroundChain {
 public:
  /// T_B_C: the rig; camera_height_m: the camera above the ground; inlier_rad: the epipolar
  /// threshold of a step's translation RANSAC.
  GroundChain(const SE3& T_B_C, double camera_height_m, double inlier_rad,
              const GroundPlaneOptions& ground, const GroundChainOptions& options = {});

  /// The frame's pose: its rotation from T_W_B_in (gyro or two-view reference), its position
  /// chained from the anchor when a step is measured (ground plane, else the last speed along
  /// the measured direction), else T_W_B_in's. A measured frame becomes the anchor.
  /// `measured` (optional) says whether the position is the chain's.
  SE3 step(const VisualFrame& frame, const SE3& T_W_B_in, bool* measured = nullptr);
  /// Starts again at this frame and pose (a standstill, a position measured otherwise).
  void restart(const VisualFrame& frame, const SE3& T_W_B);
  void reset() { anchor_.reset(); }
  /// The anchor's pose and the bearings the frame shares with it (b0 there, b1 in the frame);
  /// nullopt before the first frame.
  std::optional<SE3> sharedWithAnchor(const VisualFrame& frame, std::vector<Vec3>* b0,
                                      std::vector<Vec3>* b1) const;
  /// The last measured step's displacement over its time, world frame [m/s].
  const Vec3& velocityW() const { return velocity_W_; }

 private:
  struct Anchor {
    Timestamp t_ns = 0;
    SE3 T_W_B = SE3::Identity();
    std::unordered_map<TrackId, Vec3> bearing_C;
    int frames = 0;  // frames measured from it so far
  };
  SE3 T_B_C_;
  double height_m_;
  GroundPlaneOptions ground_;
  GroundChainOptions options_;
  TwoViewOptions two_view_;
  std::optional<Anchor> anchor_;
  std::optional<double> speed_mps_;
  Vec3 velocity_W_ = Vec3::Zero();
};

}  // namespace ovo::estimator
