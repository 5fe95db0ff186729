#include "frontend/tracker.hpp"

namespace ovo::frontend {

void TrackManager::update(std::int64_t frame_index, Timestamp t_ns, const std::vector<Vec2>& px,
                          const std::vector<Vec3>& bearings_C,
                          const std::vector<int>& feature_class,
                          const std::vector<int>& prev_index) {
  const std::vector<std::uint64_t> prev_ids = std::move(current_ids_);
  std::vector<std::uint8_t> continued(prev_ids.size(), 0);
  current_ids_.assign(px.size(), 0);
  std::unordered_map<std::uint64_t, Track> next;
  next.reserve(px.size());
  for (std::size_t j = 0; j < px.size(); ++j) {
    const TrackObservation obs{frame_index, t_ns, px[j], bearings_C[j]};
    const int p = prev_index[j];
    if (p >= 0 && p < static_cast<int>(prev_ids.size()) && !continued[p]) {
      continued[p] = 1;
      auto node = active_.extract(prev_ids[p]);
      Track& track = node.mapped();
      ++track.age;
      if (options_.max_history > 0 &&
          static_cast<int>(track.history.size()) >= options_.max_history) {
        track.history.erase(track.history.begin());
      }
      track.history.push_back(obs);
      current_ids_[j] = track.id;
      next.insert(std::move(node));
      continue;
    }
    Track track;
    track.id = next_id_++;
    track.feature_class = feature_class[j];
    track.age = 1;
    track.history.push_back(obs);
    current_ids_[j] = track.id;
    next.emplace(track.id, std::move(track));
  }
  finished_.clear();
  for (std::size_t p = 0; p < prev_ids.size(); ++p) {
    if (continued[p]) continue;
    auto it = active_.find(prev_ids[p]);
    if (it != active_.end() && it->second.age >= 2) finished_.push_back(std::move(it->second));
  }
  active_ = std::move(next);
}

std::vector<FeatureObservation> TrackManager::currentObservations() const {
  std::vector<FeatureObservation> out;
  out.reserve(current_ids_.size());
  for (const std::uint64_t id : current_ids_) {
    const Track& t = active_.at(id);
    out.push_back({id, t.last().px, t.last().bearing_C, t.age, t.feature_class});
  }
  return out;
}

const Track* TrackManager::find(std::uint64_t id) const {
  const auto it = active_.find(id);
  return it == active_.end() ? nullptr : &it->second;
}

void TrackManager::reset() {
  active_.clear();
  current_ids_.clear();
  finished_.clear();
}

}  // namespace ovo::frontend
