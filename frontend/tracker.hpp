// Feature tracks with stable ids across frames (the sliding window needs multi-frame tracks;
// libviso2 has only frame pairs): a feature matched previous -> current keeps its track id, every
// unmatched feature of the current frame starts a new track.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iterator>
#include <utility>
#include <vector>

#include "common/types.hpp"

namespace ovo::frontend {

/// One sighting of a track.
struct TrackObservation {
  std::int64_t frame_index = 0;
  Timestamp t_ns = 0;
  Vec2 px = Vec2::Zero();         // full-resolution pixel
  Vec3 bearing_C = Vec3::Zero();  // unit bearing in the camera frame
};

/// The newest sightings of a track, oldest first, read like a const std::vector. Capped appends
/// drop the oldest in blocks (a buffer of at most twice the cap): O(1) amortised per frame.
class TrackHistory {
 public:
  using const_iterator = std::vector<TrackObservation>::const_iterator;
  using const_reverse_iterator = std::reverse_iterator<const_iterator>;

  std::size_t size() const { return buffer_.size() - first_; }
  /// Sightings the buffer has room for without reallocating.
  std::size_t capacity() const { return buffer_.capacity(); }
  bool empty() const { return size() == 0; }
  const TrackObservation& operator[](std::size_t k) const { return buffer_[first_ + k]; }
  const TrackObservation& front() const { return buffer_[first_]; }
  const TrackObservation& back() const { return buffer_.back(); }
  const_iterator begin() const { return buffer_.begin() + static_cast<std::ptrdiff_t>(first_); }
  const_iterator end() const { return buffer_.end(); }
  const_reverse_iterator rbegin() const { return const_reverse_iterator(end()); }
  const_reverse_iterator rend() const { return const_reverse_iterator(begin()); }

  void clear() {
    buffer_.clear();
    first_ = 0;
  }
  /// Empties the history; a buffer with room for more than `keep` sightings is replaced by one
  /// with room for `keep`.
  void clearKeepingAtMost(std::size_t keep) {
    if (buffer_.capacity() > keep) {
      std::vector<TrackObservation> smaller;
      smaller.reserve(keep);
      buffer_.swap(smaller);
    }
    clear();
  }
  /// Appends obs; with max_size > 0 keeps only the newest max_size sightings.
  void push_back(const TrackObservation& obs, int max_size = 0) {
    buffer_.push_back(obs);
    if (max_size <= 0 || size() <= static_cast<std::size_t>(max_size)) return;
    if (++first_ >= static_cast<std::size_t>(max_size)) {
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(first_));
      first_ = 0;
    }
  }

 private:
  std::vector<TrackObservation> buffer_;
  std::size_t first_ = 0;  // sightings before first_ are dropped
};

/// A track and its history, oldest first (capped at TrackerOptions::max_history; age is not).
struct Track {
  std::uint64_t id = 0;
  int feature_class = 0;
  int age = 0;  // frames the track has lived, including the current one
  TrackHistory history;
  const TrackObservation& last() const { return history.back(); }
};

/// The current frame's view of one track.
struct FeatureObservation {
  std::uint64_t track_id = 0;
  Vec2 px = Vec2::Zero();
  Vec3 bearing_C = Vec3::Zero();
  int age = 1;
  int feature_class = 0;
};

struct TrackerOptions {
  // Observations kept per track (0 = all). The vo chain looks back to its reference frame (at most
  // vo.max_reference_frames = 6 frames) and the kf copies kf.lidar_baseline_s = 0.6 s of sightings
  // (12 frames at 20 Hz): 32 covers both with room to spare.
  int max_history = 32;
  bool operator==(const TrackerOptions&) const = default;
};

/// Owns the tracks. Call update() once per frame with the current features and, for each, the
/// index of the previous frame's feature it was matched to (or -1).
class TrackManager {
 public:
  explicit TrackManager(const TrackerOptions& options = {}) : options_(options) {}

  /// Advances to frame `frame_index`. prev_index[j] indexes the features of the previous update()
  /// (each previous feature continued at most once; later duplicates start new tracks). Tracks not
  /// continued end; those that lived at least two frames are kept in finishedTracks() until the
  /// next update().
  void update(std::int64_t frame_index, Timestamp t_ns, const std::vector<Vec2>& px,
              const std::vector<Vec3>& bearings_C, const std::vector<int>& feature_class,
              const std::vector<int>& prev_index);

  /// Track ids of the current features, in update() order.
  const std::vector<std::uint64_t>& currentIds() const { return current_ids_; }
  std::vector<FeatureObservation> currentObservations() const;
  /// The live track with this id, or nullptr (binary search).
  const Track* find(std::uint64_t id) const;
  /// The live track of current feature j (update() order).
  const Track& current(int j) const { return tracks_[j]; }
  /// The live tracks, in update() order.
  const std::vector<Track>& activeTracks() const { return tracks_; }
  /// Tracks (age >= 2) that ended at the latest update().
  const std::vector<Track>& finishedTracks() const { return finished_; }
  std::uint64_t nextId() const { return next_id_; }
  void reset();

 private:
  TrackerOptions options_;
  std::vector<Track> tracks_;                               // live tracks, one per current feature
  std::vector<std::pair<std::uint64_t, int>> index_of_id_;  // (id, feature), sorted by id
  std::vector<std::uint64_t> current_ids_;
  std::vector<Track> finished_;
  std::uint64_t next_id_ = 0;
  // Per-update scratch, kept to avoid allocation: the next frame's tracks, ended tracks whose
  // history buffers new tracks reuse, flags and the new tracks' features.
  std::vector<Track> next_, spare_;
  std::vector<std::uint8_t> continued_;
  std::vector<int> fresh_;
};

}  // namespace ovo::frontend
