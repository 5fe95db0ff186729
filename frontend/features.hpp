// libviso2-style feature detection (DESIGN section 4; Geiger, Ziegler, Stiller, "StereoScan", IV
// 2011): 5x5 Sobel / blob / checkerboard filters, four-class non-maximum suppression, 32-byte
// descriptors of Sobel samples, and the features of one frame binned on a grid for matching.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "common/types.hpp"
#include "frontend/kernels.hpp"

namespace ovo::frontend {

/// Features match only within their class.
enum class FeatureClass : std::uint8_t {
  kBlobMin = 0,
  kBlobMax = 1,
  kCornerMin = 2,
  kCornerMax = 3
};
constexpr int kNumFeatureClasses = 4;

struct DetectorOptions {
  // NMS neighbourhood (2n+1)^2 (pixels of the detection grid). libviso2 uses 3; 4 keeps fewer
  // (5: fewer still), evenly spread features on contrasted textures, and unlike a per-bin cap the
  // choice does not depend on where the grid falls, so both frames keep the same features.
  int nms_n = 4;
  int nms_n_sparse = 8;          // larger neighbourhood of the sparse (flow prior) features
  int nms_tau = 50;              // minimum |blob| or |corner| response (filter units)
  int margin_px = 8;             // no feature closer to the image edge (detection grid; >= 8)
  int bin_size_px = 50;          // matching grid cell (full-resolution pixels)
  int bin_max_features = 0;      // strongest |response| features kept per class and bin (0 = all)
  bool half_resolution = false;  // detect and match on the 2x2-averaged image
  bool operator==(const DetectorOptions&) const = default;
};

/// The filter outputs of one image (row-major, width x height of the detection grid).
struct FilterImages {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> du, dv;        // 5x5 Sobel, 128 = zero gradient
  std::vector<std::int16_t> blob, corner;  // 5x5 blob / checkerboard responses
};

/// Computes the four filters of a CV_8UC1 image (any stride).
void computeFilters(const cv::Mat& grey, FilterImages* out);

/// The 16 (du, dv) sample offsets (du_offset, dv_offset in pixels) of the descriptor; bytes 2k and
/// 2k+1 hold du and dv at offset k.
struct DescriptorOffset {
  int du;
  int dv;
};
inline constexpr std::array<DescriptorOffset, 16> kDescriptorPattern = [] {
  std::array<DescriptorOffset, 16> pattern{};
  for (int k = 0; k < 16; ++k) pattern[k] = {kernels::kPatternDu[k], kernels::kPatternDv[k]};
  return pattern;
}();

/// Writes the 32-byte descriptor at integer pixel (u, v) of the detection grid; the pixel must be
/// at least kDescriptorRadius + kFilterBorder from the edge.
void computeDescriptor(const FilterImages& filters, int u, int v, std::uint8_t* out);

/// One detected feature (detection-grid pixel; full-resolution pixel via FeatureFrame::pixel()).
struct Feature {
  std::int16_t u = 0;
  std::int16_t v = 0;
  std::int16_t value = 0;  // filter response
  FeatureClass cls = FeatureClass::kBlobMin;
  bool sparse = false;  // extremum also in the (2 nms_n_sparse + 1)^2 neighbourhood
  float du_sub = 0.0f;  // sub-pixel offset of the response peak (parabola fit), |.| <= 0.5
  float dv_sub = 0.0f;
};

/// All features of one frame, ordered by (class, bin row, bin column, raster) so that the features
/// of one class in one row of bins are contiguous; descriptors and coordinates in parallel arrays.
class FeatureFrame {
 public:
  int scale = 1;      // full-resolution pixels per detection-grid pixel (1 or 2)
  int bin_size = 50;  // detection-grid pixels per bin
  int bins_u = 0, bins_v = 0;
  FilterImages filters;
  std::vector<Feature> features;
  std::vector<std::int16_t> us, vs;       // detection-grid coordinates (SoA copy for search)
  std::vector<std::uint8_t> descriptors;  // 32 bytes per feature
  std::vector<int> bin_begin;             // (class * bins_v + row) * bins_u + col -> first index

  int size() const { return static_cast<int>(features.size()); }
  const std::uint8_t* descriptor(int i) const { return descriptors.data() + 32 * i; }
  /// Full-resolution pixel of feature i at its integer detection position (+ `refined` response
  /// sub-pixel offset). Half resolution: grid pixel c covers full pixels 2c, 2c + 1 -> 2c + 0.5.
  Vec2 pixel(int i, bool refined = false) const;
  /// Full-resolution pixel of detection-grid coordinates.
  Vec2 toFull(double u, double v) const {
    return scale == 1 ? Vec2(u, v) : Vec2(2.0 * u + 0.5, 2.0 * v + 0.5);
  }
  /// Feature index range [first, last) of class `cls` in bin row `row`, bin columns [c0, c1].
  std::pair<int, int> binRange(int cls, int row, int c0, int c1) const {
    const int base = (cls * bins_v + row) * bins_u;
    return {bin_begin[base + c0], bin_begin[base + c1 + 1]};
  }
  int binOf(double u_grid, double v_grid, int* row) const;
};

/// Wall and thread-CPU time of the two halves of extractFeatures() (milliseconds).
struct ExtractTimings {
  double filter_ms = 0.0;  // down-sampling and the four filters
  double nms_ms = 0.0;     // non-maximum suppression, binning, descriptors
  double filter_cpu_ms = 0.0;
  double nms_cpu_ms = 0.0;
};

/// Filters, detects and describes the features of `grey` (CV_8UC1). `mask` (optional, CV_8UC1 of
/// the full image size, non-zero = usable) drops features whose full-resolution pixel is masked
/// out. Reuses the buffers of *out.
void extractFeatures(const cv::Mat& grey, const DetectorOptions& options, const cv::Mat& mask,
                     FeatureFrame* out, ExtractTimings* timings = nullptr);

}  // namespace ovo::frontend
