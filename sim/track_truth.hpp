// Tracks against the simulator's truth: where the point a track started on really is in each
// later frame, and how far the track's pixel is from it. A track's first pixel is cast onto the
// world's geometry from the true pose (the point it started on); at each later sighting that
// point is projected from the true pose at the time its image row was read (rolling shutter), and
// the track's error is split into the component along the point's rotation-compensated flow (the
// image motion that translation gave it since the start: the direction a depth error moves it)
// and the one across it. Tracks are sorted by what they started on: next to a depth edge (a ray
// 6 px away sees the sky or a surface of the other kind, ground against the rest, or the inverse
// depths across the pixel bend by more than 10 %: a plane's are linear), far away (beyond 10 m), on
// the ground, or on another surface (leaves, posts, trunks). A step's error (this sighting's error
// less the previous one's) also gives the small camera rotation that best explains a frame's
// steps of each kind: averaged over the frames, the rotation bias the tracks hand an estimator.
// Leaves that sway in the wind move: on windy scenarios part of the surface kind's error is the
// leaves' true motion.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/types.hpp"

namespace ovo::sim {

class Simulation;

/// One frame's view of one track (a frontend's output: the id stays with the track).
struct TrackSighting {
  std::uint64_t track_id = 0;
  Vec2 px = Vec2::Zero();
};

enum class TrackKind { kDepthEdge = 0, kFar, kGround, kSurface };
inline constexpr int kTrackKinds = 4;
const char* trackKindName(TrackKind kind);

/// Frames since a track's first sighting at which its error is measured.
inline constexpr std::array<int, 4> kTrackErrorAges = {1, 5, 10, 20};

/// Errors of the tracks of one kind (or of all) at one age, in pixels. Errors beyond
/// kTrackJumpPx are counted as jumps (a match to another feature) and left out of the rest.
struct TrackErrorCell {
  int n = 0;                       // tracks measured (within kTrackJumpPx)
  int jumped = 0;                  // tracks further off than kTrackJumpPx
  int no_flow = 0;                 // of n: too little flow to split along / across (a standstill)
  double median_abs_along = 0.0;   // median |error along the rotation-compensated flow|
  double mean_along = 0.0;         // mean signed error along it (+: the track moved further)
  double median_abs_across = 0.0;  // median |error across it|
  double mean_across = 0.0;        // mean signed error across it (+: flow turned left, image axes)
  double median_norm = 0.0;        // median |error|
  double p90_norm = 0.0;
};
inline constexpr double kTrackJumpPx = 5.0;
/// Below this much rotation-compensated flow (px) a track's error is not split along / across.
inline constexpr double kTrackMinFlowPx = 0.05;

struct TrackTruthReport {
  int frames = 0;                                 // frames added
  std::array<int, kTrackKinds> tracks_by_kind{};  // tracks started (and classified), by kind
  int tracks_unclassified = 0;                    // first pixel saw nothing (sky) or off the model
  // [kind] and, at index kTrackKinds, all tracks together; [age index of kTrackErrorAges].
  std::array<std::array<TrackErrorCell, kTrackErrorAges.size()>, kTrackKinds + 1> cells{};
  // Mean apparent camera rotation per frame (camera x, y, z; rad) of each kind's steps, and of all
  // steps together; frames with fewer than kMinStepsForRotation steps of a kind skip that kind.
  std::array<Vec3, kTrackKinds + 1> rotation_per_frame{};
  std::array<int, kTrackKinds + 1> rotation_frames{};
  std::array<double, kTrackKinds + 1> steps_per_frame{};
  // The same without each track's first step (tracks from their second step on).
  std::array<Vec3, kTrackKinds + 1> rotation_per_frame_later{};
  std::array<int, kTrackKinds + 1> rotation_frames_later{};
  std::array<double, kTrackKinds + 1> steps_per_frame_later{};
  static constexpr int kMinStepsForRotation = 30;
};

class TrackTruth {
 public:
  explicit TrackTruth(const Simulation& sim);
  /// Frame k's tracks (in any order; an id seen for the first time starts a track, and a track
  /// missing from a frame has ended: its id starts a new one if it comes back).
  void addFrame(int k, const std::vector<TrackSighting>& sightings);
  TrackTruthReport report() const;

 private:
  struct Track {
    Vec3 p_W = Vec3::Zero();
    Vec3 b0_W = Vec3::Zero();        // first bearing in W (rotation-only reference)
    Vec3 prev_err_C = Vec3::Zero();  // previous sighting's bearing error (measured - true), C
    TrackKind kind = TrackKind::kGround;
    int sightings = 0;
    int last_frame = 0;  // addFrame() count when last seen
    bool valid = false;
  };
  struct Sample {
    double along = 0.0, across = 0.0, norm = 0.0;
    bool has_flow = false;
  };
  const Simulation& sim_;
  std::unordered_map<std::uint64_t, Track> tracks_;
  std::array<std::array<std::vector<Sample>, kTrackErrorAges.size()>, kTrackKinds> samples_;
  std::array<std::array<int, kTrackErrorAges.size()>, kTrackKinds> jumped_{};
  // [0]: every step, [1]: every step but a track's first.
  std::array<std::array<Vec3, kTrackKinds + 1>, 2> rotation_sum_{};
  std::array<std::array<int, kTrackKinds + 1>, 2> rotation_frames_{};
  std::array<std::array<long, kTrackKinds + 1>, 2> steps_{};
  std::array<int, kTrackKinds> started_{};
  int unclassified_ = 0;
  int frames_ = 0;
};

/// A plain-text table of the report (one row per kind and age).
std::string formatTrackTruth(const TrackTruthReport& report);

}  // namespace ovo::sim
