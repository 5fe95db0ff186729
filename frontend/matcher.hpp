// Previous <-> current feature matching in the manner of libviso2's matchFeatures (DESIGN section
// 4): within-class SAD search on a bin grid, circle check, a sparse pass that bounds the dense
// pass's search window per bin, sub-pixel refinement and Delaunay flow-consistency filtering.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/types.hpp"
#include "frontend/features.hpp"

namespace ovo::frontend {

/// How the matched pixels are refined below one pixel. In every mode the descriptor SSD around the
/// matched current feature is descended (8-neighbourhood, max_refine_steps) to its minimum; a match
/// that does not reach one is dropped.
enum class SubpixelMode {
  kNone,      // integer detection positions
  kCost,      // parabola through the descriptor SSD at its minimum +-1 pixel (u and v)
  kResponse,  // parabola through the filter response at each feature's own extremum
};
/// "none" | "cost" | "response"; nullopt for anything else.
std::optional<SubpixelMode> parseSubpixelMode(const std::string& name);

struct MatcherOptions {
  int search_radius_px = 100;           // half-size of the search window, no prior (full-res px)
  int search_radius_predicted_px = 30;  // ... around a rotation-predicted position
  bool sparse_pass = true;              // sparse features first, to bound the dense windows
  int flow_margin_px = 5;               // widening of each bin's sparse flow range (full-res px)
  double max_cost_ratio = 0.9;          // best / second-best SAD in the window (1 = no test)
  SubpixelMode subpixel = SubpixelMode::kCost;
  int max_refine_steps = 3;        // 8-neighbour descent steps on the SSD before the parabola
  double min_cost_contrast = 0.0;  // SSD rise to the flattest / steepest neighbour at the minimum
                                   // (drops edge features with an aperture problem; 0 = off)
  int max_queries_per_bin = 0;     // previous-frame features searched for per class and bin:
                                   // highest priority (track age) first, then strongest |response|
                                   // (0 = all); the others still take part in the circle check
  bool delaunay_filter = true;
  double delaunay_flow_tol_px = 5.0;  // neighbours whose flows differ by less support each other
  int delaunay_min_support = 4;       // supports needed to keep a match
  bool operator==(const MatcherOptions&) const = default;
};

/// One match; pixels at full resolution (refined per MatcherOptions::subpixel).
struct Match {
  int prev = -1;  // feature index in the previous FeatureFrame
  int cur = -1;   // feature index in the current FeatureFrame
  Vec2 px_prev = Vec2::Zero();
  Vec2 px_cur = Vec2::Zero();
  std::uint32_t cost = 0;  // descriptor SAD
};

/// Optional predicted positions (full-res pixels) of every feature in the other image, e.g. from a
/// gyro rotation: cur_px_of_prev[i] for previous feature i, prev_px_of_cur[j] for current feature
/// j. A zero valid flag falls back to "no motion" with the unpredicted search radius.
struct MatchPrediction {
  std::vector<Vec2> cur_px_of_prev;
  std::vector<std::uint8_t> prev_valid;
  std::vector<Vec2> prev_px_of_cur;
  std::vector<std::uint8_t> cur_valid;
};

struct MatchStats {
  int sparse_matches = 0;    // circle-checked sparse matches that survived the Delaunay filter
  int circle_matches = 0;    // dense matches passing the circle check
  int queries = 0;           // previous-frame features searched for in the dense pass
  int not_minimum = 0;       // dropped: no (well-defined) SSD minimum within max_refine_steps
  int delaunay_removed = 0;  // dense matches removed by the Delaunay filter
  // Wall time (ms) of the stages: the searches and the refinement run over the cores, so the
  // calling thread's CPU time would leave out the other threads' share.
  double sparse_ms = 0.0;    // sparse pass, including its Delaunay filter
  double dense_ms = 0.0;     // query selection, dense search and circle check
  double delaunay_ms = 0.0;  // Delaunay filter of the refined dense matches
  double refine_ms = 0.0;    // sub-pixel refinement of the circle-checked matches
};

/// Matches two frames. Holds only scratch buffers; not thread-safe.
class Matcher {
 public:
  explicit Matcher(const MatcherOptions& options = {}) : options_(options) {}

  /// Matches of previous -> current, one per feature at most, ordered by current index.
  /// prev_priority (optional, one per previous feature, e.g. its track age) orders the query
  /// choice of MatcherOptions::max_queries_per_bin.
  std::vector<Match> match(const FeatureFrame& prev, const FeatureFrame& cur,
                           const MatchPrediction* prediction = nullptr, MatchStats* stats = nullptr,
                           const std::vector<int>* prev_priority = nullptr);

  const MatcherOptions& options() const { return options_; }

 private:
  // Range of residual flow (found - predicted, detection-grid px) seen in one bin.
  struct FlowRange {
    float u_min, u_max, v_min, v_max;
    int count;
  };
  struct Window {
    int u0, u1, v0, v1;
  };
  Window window(const FeatureFrame& from, int index, const FeatureFrame& to,
                const std::vector<Vec2>* predicted, const std::vector<std::uint8_t>* valid,
                const std::vector<FlowRange>* prior) const;
  int search(const FeatureFrame& from, int index, const kernels::SearchGrid& to, const Window& w,
             std::uint32_t* cost) const;
  std::optional<Vec2> refineCost(const FeatureFrame& prev, int p, const FeatureFrame& cur,
                                 int q) const;

  // Replaces every bin's range by the union over its 3x3 bin neighbourhood.
  void mergeNeighbours(int bins_u, int bins_v, std::vector<FlowRange>* ranges);

  MatcherOptions options_;
  // Per bin of the query's image: the sparse flow range over the bin's 3x3 neighbourhood.
  std::vector<FlowRange> prior_from_cur_, prior_from_prev_;
  std::vector<FlowRange> merged_;  // scratch of mergeNeighbours
  void selectQueries(const FeatureFrame& prev, const std::vector<int>* priority);

  int recip_bin_size_ = 0;  // bin size that bin_recip_ divides by
  std::uint64_t bin_recip_ = 0;
  struct Searched {
    int index = -1;  // the match found (-1: none)
    std::uint32_t cost = 0;
  };
  // The searches of a circle check, spread over the cores (each is independent: const, no shared
  // scratch): (*forward)[i] = forward_search(i) for i < n, then (*back)[k] = back_search(k) once
  // for every k some forward search found, -2 for the others. The same as one thread searching in
  // order with a memo of the back searches.
  void circleSearches(std::size_t n,
                      const std::function<int(std::size_t, std::uint32_t*)>& forward_search,
                      std::size_t n_back, const std::function<int(int)>& back_search,
                      std::vector<Searched>* forward, std::vector<int>* back);
  std::vector<Searched> forward_;             // dense pass: each query's prev -> cur search
  std::vector<int> reverse_;                  // cur -> prev search of each current feature
  std::vector<int> back_queries_;             // scratch of circleSearches
  std::vector<std::optional<Vec2>> refined_;  // refineCost of each circle match
  std::vector<Searched> sparse_found_;        // sparse pass: each sparse cur -> prev search
  std::vector<int> sparse_reverse_;  // sparse pass: prev -> cur search of each (-2: not searched)
  std::vector<int> slot_of_cur_;     // dense match of each current feature (-1: none)
  std::vector<Match> match_buffer_;  // dense matches in query order
  std::vector<int> queries_;         // previous features searched for in the dense pass
  std::vector<int> group_;           // scratch of selectQueries
  FeatureFrame prev_sparse_, cur_sparse_;  // sparse features only
  std::vector<int> prev_sparse_index_, cur_sparse_index_;
  std::vector<std::pair<int, int>> sparse_pairs_;  // circle-checked sparse (prev, cur)
  std::vector<Vec2> px_, flow_;                    // Delaunay filter input
  std::vector<std::uint8_t> sparse_keep_, dense_keep_;
};

/// Keeps at most `max_per_bucket` matches per bucket_px x bucket_px cell of the current image:
/// highest priority first (e.g. track age), then lowest cost, then lowest index. Returns keep
/// flags.
std::vector<std::uint8_t> bucketMatches(const std::vector<Match>& matches,
                                        const std::vector<int>& priority, int bucket_px,
                                        int max_per_bucket);

}  // namespace ovo::frontend
