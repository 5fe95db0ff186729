#include "frontend/tracker.hpp"

#include <algorithm>

namespace ovo::frontend {

namespace {
// Sightings a recycled history buffer may keep room for.
constexpr std::size_t kSpareHistoryCapacity = 8;
}  // namespace

void TrackManager::update(std::int64_t frame_index, Timestamp t_ns, const std::vector<Vec2>& px,
                          const std::vector<Vec3>& bearings_C,
                          const std::vector<int>& feature_class,
                          const std::vector<int>& prev_index) {
  const std::size_t n = px.size();
  // The tracks that ended at the previous update lend their history buffers to new tracks, but
  // not a long track's large one: most new tracks end within a few frames, and a pool in which
  // every buffer that ever held a long track kept its room made the memory grow with the run's
  // length (docs/block.md).
  for (Track& t : finished_) {
    t.history.clearKeepingAtMost(kSpareHistoryCapacity);
    spare_.push_back(std::move(t));
  }
  finished_.clear();
  continued_.assign(tracks_.size(), 0);
  next_.resize(n);
  current_ids_.resize(n);
  index_of_id_.clear();
  // Continued tracks keep their (older) ids; new tracks get ids above every live one, in feature
  // order, so sorting the continued entries sorts the whole index.
  fresh_.clear();
  for (std::size_t j = 0; j < n; ++j) {
    const TrackObservation obs{frame_index, t_ns, px[j], bearings_C[j]};
    const int p = prev_index[j];
    Track& track = next_[j];
    if (p >= 0 && p < static_cast<int>(tracks_.size()) && !continued_[p]) {
      continued_[p] = 1;
      track = std::move(tracks_[p]);
      ++track.age;
      track.history.push_back(obs, options_.max_history);
      index_of_id_.emplace_back(track.id, static_cast<int>(j));
      continue;
    }
    if (!spare_.empty()) {
      track = std::move(spare_.back());
      spare_.pop_back();
    }
    track.history.clear();
    track.feature_class = feature_class[j];
    track.age = 1;
    track.history.push_back(obs);
    fresh_.push_back(static_cast<int>(j));
  }
  std::sort(index_of_id_.begin(), index_of_id_.end());
  for (const int j : fresh_) {
    next_[j].id = next_id_++;
    index_of_id_.emplace_back(next_[j].id, j);
  }
  for (std::size_t j = 0; j < n; ++j) current_ids_[j] = next_[j].id;
  for (std::size_t p = 0; p < tracks_.size(); ++p) {
    if (continued_[p]) continue;
    if (tracks_[p].age >= 2) {
      finished_.push_back(std::move(tracks_[p]));
    } else {
      spare_.push_back(std::move(tracks_[p]));
    }
  }
  std::swap(tracks_, next_);
}

std::vector<FeatureObservation> TrackManager::currentObservations() const {
  std::vector<FeatureObservation> out;
  out.reserve(tracks_.size());
  for (const Track& t : tracks_) {
    out.push_back({t.id, t.last().px, t.last().bearing_C, t.age, t.feature_class});
  }
  return out;
}

const Track* TrackManager::find(std::uint64_t id) const {
  const auto it = std::lower_bound(
      index_of_id_.begin(), index_of_id_.end(), id,
      [](const std::pair<std::uint64_t, int>& entry, std::uint64_t x) { return entry.first < x; });
  if (it == index_of_id_.end() || it->first != id) return nullptr;
  return &tracks_[it->second];
}

void TrackManager::reset() {
  tracks_.clear();
  index_of_id_.clear();
  current_ids_.clear();
  finished_.clear();
}

}  // namespace ovo::frontend
