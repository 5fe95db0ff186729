#include "frontend/features.hpp"

#include <algorithm>
#include <cmath>

#include "frontend/timing.hpp"

namespace ovo::frontend {

void computeFilters(const cv::Mat& grey, FilterImages* out) {
  const int w = grey.cols, h = grey.rows;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  out->width = w;
  out->height = h;
  out->du.resize(n);
  out->dv.resize(n);
  out->blob.resize(n);
  out->corner.resize(n);
  const int stride = static_cast<int>(grey.step[0]);
  kernels::sobel5x5(grey.data, w, h, stride, out->du.data(), out->dv.data());
  kernels::blobCorner5x5(grey.data, w, h, stride, out->blob.data(), out->corner.data());
}

void computeDescriptor(const FilterImages& filters, int u, int v, std::uint8_t* out) {
  kernels::describe(filters.du.data(), filters.dv.data(), filters.width, u, v, out);
}

Vec2 FeatureFrame::pixel(int i, bool refined) const {
  const Feature& f = features[i];
  if (!refined) return toFull(f.u, f.v);
  return toFull(f.u + f.du_sub, f.v + f.dv_sub);
}

int FeatureFrame::binOf(double u_grid, double v_grid, int* row) const {
  *row = std::clamp(static_cast<int>(v_grid) / bin_size, 0, bins_v - 1);
  return std::clamp(static_cast<int>(u_grid) / bin_size, 0, bins_u - 1);
}

namespace {

// Vertex of the parabola through (-1, l), (0, c), (1, r), limited to half a pixel.
float parabolaPeak(int l, int c, int r) {
  const int denom = l - 2 * c + r;
  if (denom == 0) return 0.0f;
  const float x = static_cast<float>(l - r) / (2.0f * static_cast<float>(denom));
  return std::clamp(x, -0.5f, 0.5f);
}

thread_local std::vector<kernels::RawFeature> t_raw;
thread_local std::vector<std::uint8_t> t_half;
thread_local std::vector<int> t_order;

// Keeps the `cap` strongest |response| candidates of every (class, bin) group (ties: earlier in
// raster order) by clearing the key of the others, and recounts the group offsets.
void capPerBin(int cap, std::vector<int>* key, std::vector<int>* begin) {
  std::vector<int>& order = t_order;
  order.resize(static_cast<std::size_t>(begin->back()));
  std::vector<int> next(begin->begin(), begin->end() - 1);
  for (std::size_t k = 0; k < key->size(); ++k) {
    if ((*key)[k] >= 0) order[next[(*key)[k]]++] = static_cast<int>(k);
  }
  const auto stronger = [](int a, int b) {
    const int va = std::abs(t_raw[a].value), vb = std::abs(t_raw[b].value);
    return va != vb ? va > vb : a < b;
  };
  const int groups = static_cast<int>(begin->size()) - 1;
  for (int g = 0; g < groups; ++g) {
    const int first = (*begin)[g], last = (*begin)[g + 1];
    if (last - first <= cap) continue;
    std::nth_element(order.begin() + first, order.begin() + first + cap - 1, order.begin() + last,
                     stronger);
    for (int i = first + cap; i < last; ++i) (*key)[order[i]] = -1;
  }
  // next[g] is now the end of group g.
  for (int g = 0; g < groups; ++g) {
    (*begin)[g + 1] = (*begin)[g] + std::min(cap, next[g] - (g == 0 ? 0 : next[g - 1]));
  }
}

}  // namespace

void extractFeatures(const cv::Mat& grey, const DetectorOptions& options, const cv::Mat& mask,
                     FeatureFrame* out, ExtractTimings* timings) {
  CV_Assert(grey.type() == CV_8UC1);
  StageClock clock;
  ExtractTimings local_timings;
  const bool half = options.half_resolution;
  out->scale = half ? 2 : 1;
  if (half) {
    const int w2 = grey.cols / 2, h2 = grey.rows / 2;
    t_half.resize(static_cast<std::size_t>(w2) * h2);
    kernels::halfResolution(grey.data, grey.cols, grey.rows, static_cast<int>(grey.step[0]),
                            t_half.data());
    computeFilters(cv::Mat(h2, w2, CV_8UC1, t_half.data()), &out->filters);
  } else {
    computeFilters(grey, &out->filters);
  }
  const FilterImages& f = out->filters;
  clock.lap(&local_timings.filter_ms, &local_timings.filter_cpu_ms);
  const int margin = std::max(options.margin_px / out->scale,
                              kernels::kDescriptorRadius + kernels::kFilterBorder + 1);
  kernels::nonMaximumSuppression(f.blob.data(), f.corner.data(), f.width, f.height, options.nms_n,
                                 options.nms_n_sparse, options.nms_tau, margin, &t_raw);

  out->bin_size = std::max(1, options.bin_size_px / out->scale);
  out->bins_u = std::max(1, (f.width + out->bin_size - 1) / out->bin_size);
  out->bins_v = std::max(1, (f.height + out->bin_size - 1) / out->bin_size);
  const int bins = out->bins_u * out->bins_v;
  const bool use_mask = !mask.empty();
  CV_Assert(!use_mask ||
            (mask.type() == CV_8UC1 && mask.cols == grey.cols && mask.rows == grey.rows));

  // Counting sort of the kept candidates by (class, bin row, bin column); stable in raster order.
  std::vector<int>& begin = out->bin_begin;
  begin.assign(kNumFeatureClasses * bins + 1, 0);
  std::vector<int> key(t_raw.size(), -1);
  for (std::size_t k = 0; k < t_raw.size(); ++k) {
    const kernels::RawFeature& r = t_raw[k];
    if (use_mask) {
      const Vec2 px = out->toFull(r.u, r.v);
      if (!mask.at<std::uint8_t>(static_cast<int>(px.y()), static_cast<int>(px.x()))) continue;
    }
    int row = 0;
    const int col = out->binOf(r.u, r.v, &row);
    key[k] = (r.cls * out->bins_v + row) * out->bins_u + col;
    ++begin[key[k] + 1];
  }
  for (int b = 0; b < kNumFeatureClasses * bins; ++b) begin[b + 1] += begin[b];
  const int cap = options.bin_max_features;
  if (cap > 0) capPerBin(cap, &key, &begin);
  const int n = begin.back();
  out->features.resize(n);
  out->us.resize(n);
  out->vs.resize(n);
  out->descriptors.resize(static_cast<std::size_t>(n) * kernels::kDescriptorBytes);
  std::vector<int> next(begin.begin(), begin.end() - 1);
  const int w = f.width;
  for (std::size_t k = 0; k < t_raw.size(); ++k) {
    if (key[k] < 0) continue;
    const kernels::RawFeature& r = t_raw[k];
    const int i = next[key[k]]++;
    Feature& feat = out->features[i];
    feat.u = r.u;
    feat.v = r.v;
    feat.value = r.value;
    feat.cls = static_cast<FeatureClass>(r.cls);
    const bool is_blob = r.cls < 2;
    const std::int16_t* response = is_blob ? f.blob.data() : f.corner.data();
    feat.sparse = r.sparse != 0;
    const std::ptrdiff_t c = static_cast<std::ptrdiff_t>(r.v) * w + r.u;
    feat.du_sub = parabolaPeak(response[c - 1], response[c], response[c + 1]);
    feat.dv_sub = parabolaPeak(response[c - w], response[c], response[c + w]);
    out->us[i] = r.u;
    out->vs[i] = r.v;
    computeDescriptor(f, r.u, r.v, out->descriptors.data() + static_cast<std::size_t>(i) * 32);
  }
  clock.lap(&local_timings.nms_ms, &local_timings.nms_cpu_ms);
  if (timings) *timings = local_timings;
}

}  // namespace ovo::frontend
