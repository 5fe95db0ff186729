#include "frontend/matcher.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>

#include "frontend/delaunay.hpp"
#include "frontend/timing.hpp"

namespace ovo::frontend {
namespace {

constexpr std::uint32_t kNoCost = std::numeric_limits<std::uint32_t>::max();
// Searches (or cost refinements) per task where the matcher spreads them over the cores.
constexpr std::size_t kSearchGrain = 256;

Vec2 toGrid(const FeatureFrame& frame, const Vec2& px_full) {
  return frame.scale == 1 ? px_full : Vec2((px_full.x() - 0.5) / 2.0, (px_full.y() - 0.5) / 2.0);
}

// std::floor / std::ceil for |x| < 2^31, without the SSE2 emulation of rounding instructions.
int floorToInt(double x) {
  const int i = static_cast<int>(x);
  return i - (x < i);
}
int ceilToInt(double x) {
  const int i = static_cast<int>(x);
  return i + (x > i);
}

// Vertex of the parabola through (-1, l), (0, c), (1, r); nullopt unless c is the minimum of the
// three (then the vertex lies within +-0.5).
std::optional<double> parabolaMinimum(double l, double c, double r) {
  if (c > l || c > r) return std::nullopt;
  const double denom = l - 2.0 * c + r;
  if (denom <= 0.0) return 0.0;
  return (l - r) / (2.0 * denom);
}

// Where feature `index` of `from` is expected in the other image (detection grid).
Vec2 predictedCentre(const FeatureFrame& from, int index, const FeatureFrame& to,
                     const std::vector<Vec2>* predicted, const std::vector<std::uint8_t>* valid,
                     bool* is_predicted) {
  const Feature& f = from.features[index];
  *is_predicted = predicted && (*valid)[index];
  if (*is_predicted) return toGrid(to, (*predicted)[index]);
  return Vec2(f.u, f.v);
}

// The sparse features of `in` as a searchable frame of their own (no filter images); index[k] is
// the feature of `in` that subset feature k copies.
void sparseSubset(const FeatureFrame& in, FeatureFrame* out, std::vector<int>* index) {
  out->scale = in.scale;
  out->bin_size = in.bin_size;
  out->bins_u = in.bins_u;
  out->bins_v = in.bins_v;
  out->filters.width = in.filters.width;
  out->filters.height = in.filters.height;
  out->features.clear();
  out->us.clear();
  out->vs.clear();
  out->descriptors.clear();
  index->clear();
  out->bin_begin.assign(in.bin_begin.size(), 0);
  for (std::size_t b = 0; b + 1 < in.bin_begin.size(); ++b) {
    out->bin_begin[b] = static_cast<int>(out->features.size());
    for (int i = in.bin_begin[b]; i < in.bin_begin[b + 1]; ++i) {
      if (!in.features[i].sparse) continue;
      out->features.push_back(in.features[i]);
      out->us.push_back(in.us[i]);
      out->vs.push_back(in.vs[i]);
      out->descriptors.insert(out->descriptors.end(), in.descriptor(i),
                              in.descriptor(i) + kernels::kDescriptorBytes);
      index->push_back(i);
    }
  }
  out->bin_begin.back() = static_cast<int>(out->features.size());
}

// The search view of a frame (pointers into it: valid while the frame is unchanged).
kernels::SearchGrid searchGrid(const FeatureFrame& frame) {
  kernels::SearchGrid g;
  g.descs = frame.descriptors.data();
  g.us = frame.us.data();
  g.vs = frame.vs.data();
  g.bin_begin = frame.bin_begin.data();
  g.size = frame.size();
  g.bins_u = frame.bins_u;
  g.bins_v = frame.bins_v;
  g.bin_size = frame.bin_size;
  g.width = frame.filters.width;
  g.height = frame.filters.height;
  g.bin_recip = kernels::binReciprocal(frame.bin_size);
  return g;
}

}  // namespace

void Matcher::mergeNeighbours(int bins_u, int bins_v, std::vector<FlowRange>* ranges) {
  merged_ = *ranges;
  for (int row = 0; row < bins_v; ++row) {
    for (int col = 0; col < bins_u; ++col) {
      FlowRange r{std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(),
                  std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(), 0};
      for (int rr = std::max(0, row - 1); rr <= std::min(bins_v - 1, row + 1); ++rr) {
        for (int cc = std::max(0, col - 1); cc <= std::min(bins_u - 1, col + 1); ++cc) {
          const FlowRange& b = merged_[rr * bins_u + cc];
          if (b.count == 0) continue;
          r.u_min = std::min(r.u_min, b.u_min);
          r.u_max = std::max(r.u_max, b.u_max);
          r.v_min = std::min(r.v_min, b.v_min);
          r.v_max = std::max(r.v_max, b.v_max);
          r.count += b.count;
        }
      }
      (*ranges)[row * bins_u + col] = r;
    }
  }
}

std::optional<SubpixelMode> parseSubpixelMode(const std::string& name) {
  if (name == "none") return SubpixelMode::kNone;
  if (name == "cost") return SubpixelMode::kCost;
  if (name == "response") return SubpixelMode::kResponse;
  return std::nullopt;
}

Matcher::Window Matcher::window(const FeatureFrame& from, int index, const FeatureFrame& to,
                                const std::vector<Vec2>* predicted,
                                const std::vector<std::uint8_t>* valid,
                                const std::vector<FlowRange>* prior) const {
  bool is_predicted = false;
  const Vec2 c = predictedCentre(from, index, to, predicted, valid, &is_predicted);
  const double radius =
      (is_predicted ? options_.search_radius_predicted_px : options_.search_radius_px) /
      static_cast<double>(to.scale);
  double u_lo = c.x() - radius, u_hi = c.x() + radius;
  double v_lo = c.y() - radius, v_hi = c.y() + radius;
  if (prior) {
    const Feature& f = from.features[index];
    int row = 0, col = 0;
    if (from.bin_size == recip_bin_size_ && f.u >= 0 && f.v >= 0) {  // the common case, no idiv
      col = std::min(kernels::binIndex(f.u, bin_recip_), from.bins_u - 1);
      row = std::min(kernels::binIndex(f.v, bin_recip_), from.bins_v - 1);
    } else {
      col = from.binOf(f.u, f.v, &row);
    }
    const FlowRange& r = (*prior)[row * from.bins_u + col];
    if (r.count > 0) {
      const double m = options_.flow_margin_px / static_cast<double>(to.scale);
      u_lo = std::max(u_lo, c.x() + r.u_min - m);
      u_hi = std::min(u_hi, c.x() + r.u_max + m);
      v_lo = std::max(v_lo, c.y() + r.v_min - m);
      v_hi = std::min(v_hi, c.y() + r.v_max + m);
    }
  }
  return {ceilToInt(u_lo), floorToInt(u_hi), ceilToInt(v_lo), floorToInt(v_hi)};
}

int Matcher::search(const FeatureFrame& from, int index, const kernels::SearchGrid& to,
                    const Window& w, std::uint32_t* cost) const {
  int best = -1;
  std::uint32_t second = kNoCost;
  kernels::searchWindow(from.descriptor(index), to, static_cast<int>(from.features[index].cls),
                        w.u0, w.u1, w.v0, w.v1, &best, cost, &second);
  // Uniqueness: the runner-up must be clearly worse (integer form of best / second < ratio).
  if (best >= 0 && second != kNoCost &&
      static_cast<double>(*cost) > options_.max_cost_ratio * static_cast<double>(second)) {
    return -1;
  }
  return best;
}

std::optional<Vec2> Matcher::refineCost(const FeatureFrame& prev, int p, const FeatureFrame& cur,
                                        int q) const {
  const Feature& f = cur.features[q];
  const std::uint8_t* ref = prev.descriptor(p);
  const FilterImages& filters = cur.filters;
  // Positions whose descriptor lies inside the filtered area.
  const int lo = kernels::kDescriptorRadius + kernels::kFilterBorder;
  const int u_hi = filters.width - 1 - lo, v_hi = filters.height - 1 - lo;
  // SSD of the 3x3 neighbourhood, index (dv + 1) * 3 + du + 1; kOutside for positions outside the
  // area (above every SSD: 32 * 255^2 < 2^21).
  constexpr std::uint32_t kOutside = std::numeric_limits<std::uint32_t>::max();
  std::uint32_t around[9];
  const auto ssdAround = [&](int u, int v) {
    if (u > lo && v > lo && u < u_hi && v < v_hi) {
      kernels::ssdAround(filters.du.data(), filters.dv.data(), filters.width, u, v, ref, around);
      return;
    }
    std::uint8_t d[kernels::kDescriptorBytes];
    for (int k = 0; k < 9; ++k) {
      const int du = k % 3 - 1, dv = k / 3 - 1;
      around[k] = kOutside;
      if (u + du < lo || v + dv < lo || u + du > u_hi || v + dv > v_hi) continue;
      computeDescriptor(filters, u + du, v + dv, d);
      around[k] = kernels::ssd32(ref, d);
    }
  };
  // kOutside as "infinitely" expensive.
  const auto cost = [](std::uint32_t x) {
    return x == kOutside ? std::numeric_limits<double>::max() : static_cast<double>(x);
  };
  // Descend on the SSD over the 8-neighbourhood from the matched feature: a feature detected a
  // little off the true position (typical along edges) moves to the cost minimum.
  int u = f.u, v = f.v;
  ssdAround(u, v);
  std::uint32_t second = kOutside, worst = 0;  // cheapest / dearest neighbour at the minimum
  for (int step = 0;; ++step) {
    const std::uint32_t c = around[4];
    int best_k = 4;
    std::uint32_t best = c;
    second = kOutside;
    worst = c;
    for (int k = 0; k < 9; ++k) {
      if (k == 4) continue;
      const std::uint32_t x = around[k];
      second = std::min(second, x);
      worst = std::max(worst, x);
      if (x < best) best = x, best_k = k;
    }
    if (best_k == 4) break;
    if (step == options_.max_refine_steps) return std::nullopt;
    u += best_k % 3 - 1;
    v += best_k / 3 - 1;
    ssdAround(u, v);
  }
  // Response mode reports the feature's own position: it must be the cost minimum.
  if (options_.subpixel == SubpixelMode::kResponse && (u != f.u || v != f.v)) return std::nullopt;
  // Aperture check: along a straight edge the SSD barely rises in one direction.
  const double c = cost(around[4]);
  if (cost(second) - c < options_.min_cost_contrast * (cost(worst) - c)) return std::nullopt;
  const auto ou = parabolaMinimum(cost(around[3]), c, cost(around[5]));
  const auto ov = parabolaMinimum(cost(around[1]), c, cost(around[7]));
  if (!ou || !ov) return std::nullopt;
  return cur.toFull(u + *ou, v + *ov);
}

void Matcher::selectQueries(const FeatureFrame& prev, const std::vector<int>* priority) {
  queries_.clear();
  const int cap = options_.max_queries_per_bin;
  const int groups = static_cast<int>(prev.bin_begin.size()) - 1;
  const auto prio = [&](int i) { return priority ? (*priority)[i] : 0; };
  // Higher priority, then stronger response, then lower index.
  const auto before = [&](int a, int b) {
    if (prio(a) != prio(b)) return prio(a) > prio(b);
    const int va = std::abs(prev.features[a].value), vb = std::abs(prev.features[b].value);
    return va != vb ? va > vb : a < b;
  };
  for (int g = 0; g < groups; ++g) {
    const int first = prev.bin_begin[g], last = prev.bin_begin[g + 1];
    if (cap <= 0 || last - first <= cap) {
      for (int i = first; i < last; ++i) queries_.push_back(i);
      continue;
    }
    group_.resize(last - first);
    std::iota(group_.begin(), group_.end(), first);
    std::nth_element(group_.begin(), group_.begin() + cap - 1, group_.end(), before);
    queries_.insert(queries_.end(), group_.begin(), group_.begin() + cap);
  }
}

void Matcher::circleSearches(std::size_t n,
                             const std::function<int(std::size_t, std::uint32_t*)>& forward_search,
                             std::size_t n_back, const std::function<int(int)>& back_search,
                             std::vector<Searched>* forward, std::vector<int>* back) {
  forward->resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kSearchGrain),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        Searched& f = (*forward)[i];
                        f.cost = 0;
                        f.index = forward_search(i, &f.cost);
                      }
                    });
  back->assign(n_back, -2);  // -2: not searched
  back_queries_.clear();
  for (const Searched& f : *forward) {
    if (f.index >= 0 && (*back)[f.index] == -2) {
      (*back)[f.index] = -1;
      back_queries_.push_back(f.index);
    }
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, back_queries_.size(), kSearchGrain),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i)
                        (*back)[back_queries_[i]] = back_search(back_queries_[i]);
                    });
}

std::vector<Match> Matcher::match(const FeatureFrame& prev, const FeatureFrame& cur,
                                  const MatchPrediction* prediction, MatchStats* stats,
                                  const std::vector<int>* prev_priority) {
  MatchStats local_stats;
  const std::vector<Vec2>* pred_cur_of_prev = prediction ? &prediction->cur_px_of_prev : nullptr;
  const std::vector<std::uint8_t>* prev_valid = prediction ? &prediction->prev_valid : nullptr;
  const std::vector<Vec2>* pred_prev_of_cur = prediction ? &prediction->prev_px_of_cur : nullptr;
  const std::vector<std::uint8_t>* cur_valid = prediction ? &prediction->cur_valid : nullptr;

  recip_bin_size_ = prev.bin_size;
  bin_recip_ = kernels::binReciprocal(prev.bin_size);
  const double t0 = wallMs();
  // Sparse pass: circle-checked matches among the sparse features over the full window.
  const bool use_prior = options_.sparse_pass;
  if (use_prior) {
    sparseSubset(prev, &prev_sparse_, &prev_sparse_index_);
    sparseSubset(cur, &cur_sparse_, &cur_sparse_index_);
    const kernels::SearchGrid prev_sparse_grid = searchGrid(prev_sparse_);
    const kernels::SearchGrid cur_sparse_grid = searchGrid(cur_sparse_);
    std::vector<std::pair<int, int>>& sparse = sparse_pairs_;
    sparse.clear();
    std::vector<Searched>& found = sparse_found_;  // each sparse current -> previous search
    circleSearches(
        cur_sparse_index_.size(),
        [&](std::size_t i, std::uint32_t* cost) {
          const int q = cur_sparse_index_[i];
          return search(cur, q, prev_sparse_grid,
                        window(cur, q, prev, pred_prev_of_cur, cur_valid, nullptr), cost);
        },
        prev_sparse_.size(),
        [&](int p_sub) {
          const int p = prev_sparse_index_[p_sub];
          std::uint32_t cost = 0;
          return search(prev, p, cur_sparse_grid,
                        window(prev, p, cur, pred_cur_of_prev, prev_valid, nullptr), &cost);
        },
        &found, &sparse_reverse_);
    for (std::size_t i = 0; i < cur_sparse_index_.size(); ++i) {
      const int q = cur_sparse_index_[i], p_sub = found[i].index;
      if (p_sub < 0) continue;
      const int q2_sub = sparse_reverse_[p_sub];
      if (q2_sub >= 0 && cur_sparse_index_[q2_sub] == q)
        sparse.emplace_back(prev_sparse_index_[p_sub], q);
    }
    px_.resize(sparse.size());
    flow_.resize(sparse.size());
    for (std::size_t k = 0; k < sparse.size(); ++k) {
      px_[k] = cur.pixel(sparse[k].second);
      flow_[k] = px_[k] - prev.pixel(sparse[k].first);
    }
    sparse_keep_.assign(sparse.size(), 1);
    if (options_.delaunay_filter) {
      delaunaySupportFilter(px_, flow_, options_.delaunay_flow_tol_px,
                            options_.delaunay_min_support, &sparse_keep_);
    }
    const FlowRange empty{0.f, 0.f, 0.f, 0.f, 0};
    prior_from_cur_.assign(static_cast<std::size_t>(cur.bins_u) * cur.bins_v, empty);
    prior_from_prev_.assign(static_cast<std::size_t>(prev.bins_u) * prev.bins_v, empty);
    const auto add = [](FlowRange& r, const Vec2& flow_grid) {
      const float u = static_cast<float>(flow_grid.x()), v = static_cast<float>(flow_grid.y());
      if (r.count == 0) {
        r = {u, u, v, v, 1};
        return;
      }
      r.u_min = std::min(r.u_min, u);
      r.u_max = std::max(r.u_max, u);
      r.v_min = std::min(r.v_min, v);
      r.v_max = std::max(r.v_max, v);
      ++r.count;
    };
    for (std::size_t k = 0; k < sparse.size(); ++k) {
      if (!sparse_keep_[k]) continue;
      ++local_stats.sparse_matches;
      const auto [p, q] = sparse[k];
      const Feature& fp = prev.features[p];
      const Feature& fq = cur.features[q];
      bool predicted = false;
      int row = 0;
      int col = cur.binOf(fq.u, fq.v, &row);
      add(prior_from_cur_[row * cur.bins_u + col],
          Vec2(fp.u, fp.v) -
              predictedCentre(cur, q, prev, pred_prev_of_cur, cur_valid, &predicted));
      col = prev.binOf(fp.u, fp.v, &row);
      add(prior_from_prev_[row * prev.bins_u + col],
          Vec2(fq.u, fq.v) -
              predictedCentre(prev, p, cur, pred_cur_of_prev, prev_valid, &predicted));
    }
    mergeNeighbours(cur.bins_u, cur.bins_v, &prior_from_cur_);
    mergeNeighbours(prev.bins_u, prev.bins_v, &prior_from_prev_);
  }

  const double t1 = wallMs();
  // Dense pass with circle check previous -> current -> previous.
  selectQueries(prev, prev_priority);
  local_stats.queries = static_cast<int>(queries_.size());
  const kernels::SearchGrid prev_grid = searchGrid(prev), cur_grid = searchGrid(cur);
  // A current feature matches at most one previous one (the result of its reverse search): the
  // matches go to slot_of_cur_ and come out ordered by current index.
  circleSearches(
      queries_.size(),
      [&](std::size_t i, std::uint32_t* cost) {
        const int p = queries_[i];
        return search(prev, p, cur_grid,
                      window(prev, p, cur, pred_cur_of_prev, prev_valid,
                             use_prior ? &prior_from_prev_ : nullptr),
                      cost);
      },
      cur.size(),
      [&](int q) {
        std::uint32_t back_cost = 0;
        return search(cur, q, prev_grid,
                      window(cur, q, prev, pred_prev_of_cur, cur_valid,
                             use_prior ? &prior_from_cur_ : nullptr),
                      &back_cost);
      },
      &forward_, &reverse_);
  match_buffer_.clear();
  slot_of_cur_.assign(cur.size(), -1);
  const bool response = options_.subpixel == SubpixelMode::kResponse;
  for (std::size_t i = 0; i < queries_.size(); ++i) {
    const int p = queries_[i], q = forward_[i].index;
    if (q < 0 || reverse_[q] != p) continue;
    Match m;
    m.prev = p;
    m.cur = q;
    m.cost = forward_[i].cost;
    m.px_prev = prev.pixel(p, response);
    m.px_cur = cur.pixel(q, response);
    slot_of_cur_[q] = static_cast<int>(match_buffer_.size());
    match_buffer_.push_back(m);
  }
  std::vector<Match> matches;
  matches.reserve(match_buffer_.size());
  for (const int slot : slot_of_cur_) {
    if (slot >= 0) matches.push_back(match_buffer_[slot]);
  }
  local_stats.circle_matches = static_cast<int>(matches.size());
  const double t2 = wallMs();

  // Sub-pixel refinement (and the SSD-minimum check of every mode), before the Delaunay filter so
  // that only well-localised matches support their neighbours.
  refined_.resize(matches.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, matches.size(), kSearchGrain),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t k = range.begin(); k != range.end(); ++k)
                        refined_[k] = refineCost(prev, matches[k].prev, cur, matches[k].cur);
                    });
  std::size_t num_refined = 0;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    Match m = matches[k];
    if (!refined_[k]) {
      ++local_stats.not_minimum;
      continue;
    }
    if (options_.subpixel == SubpixelMode::kCost) m.px_cur = *refined_[k];
    matches[num_refined++] = m;
  }
  matches.resize(num_refined);
  const double t3 = wallMs();

  if (options_.delaunay_filter && !matches.empty()) {
    px_.resize(matches.size());
    flow_.resize(matches.size());
    for (std::size_t k = 0; k < matches.size(); ++k) {
      px_[k] = matches[k].px_cur;
      flow_[k] = matches[k].px_cur - matches[k].px_prev;
    }
    delaunaySupportFilter(px_, flow_, options_.delaunay_flow_tol_px, options_.delaunay_min_support,
                          &dense_keep_);
    std::size_t kept = 0;
    for (std::size_t k = 0; k < matches.size(); ++k) {
      if (dense_keep_[k]) matches[kept++] = matches[k];
    }
    local_stats.delaunay_removed = static_cast<int>(matches.size() - kept);
    matches.resize(kept);
  }
  const double t4 = wallMs();
  local_stats.sparse_ms = t1 - t0;
  local_stats.dense_ms = t2 - t1;
  local_stats.refine_ms = t3 - t2;
  local_stats.delaunay_ms = t4 - t3;
  if (stats) *stats = local_stats;
  return matches;
}

std::vector<std::uint8_t> bucketMatches(const std::vector<Match>& matches,
                                        const std::vector<int>& priority, int bucket_px,
                                        int max_per_bucket) {
  const int n = static_cast<int>(matches.size());
  std::vector<std::uint8_t> keep(n, 0);
  if (max_per_bucket <= 0 || bucket_px <= 0) {
    std::fill(keep.begin(), keep.end(), 1);
    return keep;
  }
  if (n == 0) return keep;
  // Bucket (row, column) of every match, relative to the lowest ones present.
  std::vector<std::int64_t> bu(n), bv(n);
  std::int64_t bu_min = std::numeric_limits<std::int64_t>::max(), bv_min = bu_min;
  std::int64_t bu_max = std::numeric_limits<std::int64_t>::lowest(), bv_max = bu_max;
  for (int i = 0; i < n; ++i) {
    bu[i] = static_cast<std::int64_t>(std::floor(matches[i].px_cur.x() / bucket_px));
    bv[i] = static_cast<std::int64_t>(std::floor(matches[i].px_cur.y() / bucket_px));
    bu_min = std::min(bu_min, bu[i]);
    bu_max = std::max(bu_max, bu[i]);
    bv_min = std::min(bv_min, bv[i]);
    bv_max = std::max(bv_max, bv[i]);
  }
  const auto prio = [&](int i) { return priority.empty() ? 0 : priority[i]; };
  // Higher priority, then lower cost, then lower index.
  const auto before = [&](int a, int b) {
    if (prio(a) != prio(b)) return prio(a) > prio(b);
    if (matches[a].cost != matches[b].cost) return matches[a].cost < matches[b].cost;
    return a < b;
  };
  const std::int64_t cols = bu_max - bu_min + 1, rows = bv_max - bv_min + 1;
  if (cols * rows > 4 * static_cast<std::int64_t>(n) + 1024) {
    // Sparse buckets (e.g. far-apart pixels): sort by bucket.
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      if (bv[a] != bv[b]) return bv[a] < bv[b];
      if (bu[a] != bu[b]) return bu[a] < bu[b];
      return before(a, b);
    });
    int taken = 0;
    for (int k = 0; k < n; ++k) {
      const int i = order[k];
      if (k > 0 && (bu[i] != bu[order[k - 1]] || bv[i] != bv[order[k - 1]])) taken = 0;
      if (taken < max_per_bucket) {
        keep[i] = 1;
        ++taken;
      }
    }
    return keep;
  }
  // Counting sort by bucket, then the max_per_bucket first of each bucket's matches.
  std::vector<int> begin(static_cast<std::size_t>(cols * rows) + 1, 0), order(n);
  const auto bucketOf = [&](int i) { return (bv[i] - bv_min) * cols + (bu[i] - bu_min); };
  for (int i = 0; i < n; ++i) ++begin[bucketOf(i) + 1];
  for (std::size_t b = 1; b < begin.size(); ++b) begin[b] += begin[b - 1];
  std::vector<int> next(begin.begin(), begin.end() - 1);
  for (int i = 0; i < n; ++i) order[next[bucketOf(i)]++] = i;
  for (std::size_t b = 0; b + 1 < begin.size(); ++b) {
    const auto first = order.begin() + begin[b], last = order.begin() + begin[b + 1];
    if (last - first > max_per_bucket) {
      std::nth_element(first, first + max_per_bucket - 1, last, before);
      for (auto it = first; it != first + max_per_bucket; ++it) keep[*it] = 1;
    } else {
      for (auto it = first; it != last; ++it) keep[*it] = 1;
    }
  }
  return keep;
}

}  // namespace ovo::frontend
