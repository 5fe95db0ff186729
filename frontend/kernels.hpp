// Hot per-pixel and per-descriptor kernels of the libviso2-style frontend (DESIGN section 4), with
// plain-pointer interfaces so that kernels_simd.cpp and track_refine_simd.cpp (the Lucas-Kanade
// step) can be compiled for the native ISA.
// Images are row-major with a row stride in elements; outputs have the input's width and height.
#pragma once

#include <cstdint>
#include <vector>

namespace ovo::frontend::kernels {

constexpr int kDescriptorBytes = 32;
constexpr int kFilterBorder = 2;  // filter outputs within this many pixels of the edge are neutral
constexpr int kDescriptorRadius = 5;  // largest |offset| of a descriptor sample

/// The 16 descriptor sample offsets (pixels): four samples at radius sqrt(2), then rings at 3,
/// 3 sqrt(2) and 5 pixels; bytes 2k and 2k + 1 of a descriptor hold du and dv at offset k.
constexpr std::int8_t kPatternDu[16] = {-1, 1, -1, 1, -3, 3, 0, 0, -3, 3, -3, 3, -5, 5, 0, 0};
constexpr std::int8_t kPatternDv[16] = {-1, -1, 1, 1, 0, 0, -3, 3, -3, -3, 3, 3, 0, 0, -5, 5};

/// 5x5 Sobel: du = [1 4 6 4 1]^T (vertical smoothing) x [-1 -2 0 2 1] (horizontal derivative, as
/// correlation, positive where intensity grows with u); dv likewise transposed. Output is
/// sat8((sum >> 7) + 128), so a unit-slope ramp gives 129. Border pixels are 128.
void sobel5x5(const std::uint8_t* img, int width, int height, int stride, std::uint8_t* du,
              std::uint8_t* dv);

/// 5x5 blob (outer ring -1, inner ring +1, centre +8; sums to zero) and checkerboard
/// [-1 -1 0 1 1; -1 -1 0 1 1; 0 0 0 0 0; 1 1 0 -1 -1; 1 1 0 -1 -1] responses (correlation).
/// Border pixels are 0.
void blobCorner5x5(const std::uint8_t* img, int width, int height, int stride, std::int16_t* blob,
                   std::int16_t* corner);

/// 2x2 box down-sampling: out(r, c) = round(mean of img(2r..2r+1, 2c..2c+1)); out is
/// (width / 2) x (height / 2), dense.
void halfResolution(const std::uint8_t* img, int width, int height, int stride, std::uint8_t* out);

/// A non-maximum-suppression result: pixel, response, class (FeatureClass in features.hpp).
struct RawFeature {
  std::int16_t u;
  std::int16_t v;
  std::int16_t value;
  std::uint8_t cls;
  std::uint8_t sparse;  // also the extremum of the (2 n_sparse + 1)^2 neighbourhood
};

/// Non-maximum suppression (the result of libviso2's / Neubeck-Van Gool's block scheme): a pixel
/// is kept when no pixel of its (2n+1)^2 neighbourhood (clipped to the image) is more extreme, ties
/// going to the earlier pixel in raster order, and |value| >= tau. Only pixels at least `margin`
/// from the edge are considered. Computed with separable sliding-window max / min filters, so the
/// cost does not grow with the number of candidates. Classes: 0 blob min, 1 blob max, 2 corner min,
/// 3 corner max. Output in raster order, classes ascending at one pixel.
void nonMaximumSuppression(const std::int16_t* blob, const std::int16_t* corner, int width,
                           int height, int n, int n_sparse, int tau, int margin,
                           std::vector<RawFeature>* out);

/// out = the max (is_max) or min of `in` over the (2 r + 1)^2 window clipped to the image.
void extremumFilter(const std::int16_t* in, int width, int height, int r, bool is_max,
                    std::int16_t* out);

/// True when `value` at (u, v) is the extremum (max for is_max, else min) of its
/// (2 radius + 1)^2 neighbourhood of `response` (same tie rule as above).
bool isExtremum(const std::int16_t* response, int width, int height, int u, int v, int radius,
                bool is_max);

/// Sum of absolute differences of two 32-byte descriptors.
std::uint32_t sad32(const std::uint8_t* a, const std::uint8_t* b);

/// Sum of squared differences of two 32-byte descriptors.
std::uint32_t ssd32(const std::uint8_t* a, const std::uint8_t* b);

/// Writes the 32-byte descriptor at pixel (u, v) of the Sobel planes du, dv (row stride
/// `width`); (u, v) at least kDescriptorRadius from the edge.
void describe(const std::uint8_t* du, const std::uint8_t* dv, int width, int u, int v,
              std::uint8_t* out);

/// SSD of `ref` against the descriptors at the 3x3 pixels around (u, v):
/// out[(dv + 1) * 3 + du + 1] for du, dv in {-1, 0, 1}; (u, v) at least kDescriptorRadius + 1 from
/// the edge. Equal to ssd32(ref, describe(u + du, v + dv)).
void ssdAround(const std::uint8_t* du, const std::uint8_t* dv, int width, int u, int v,
               const std::uint8_t* ref, std::uint32_t* out);

/// Best (lowest SAD, lowest index on ties) candidate i in [begin, end) with
/// u0 <= us[i] <= u1 and v0 <= vs[i] <= v1; descriptors of candidate i at descs + 32 i. One by one
/// in index order: searchWindow's path on CPUs without AVX-512.
/// Updates *best_index / *best_cost only when a candidate beats *best_cost, and *second_cost to
/// the lowest cost of the other candidates seen.
void searchBest(const std::uint8_t* query, const std::uint8_t* descs, const std::int16_t* us,
                const std::int16_t* vs, int begin, int end, int u0, int u1, int v0, int v1,
                int* best_index, std::uint32_t* best_cost, std::uint32_t* second_cost);

/// The binned features of one frame as searchWindow sees them: feature i of class c lies in bin
/// (row, col) with bin_begin[(c * bins_v + row) * bins_u + col] <= i < ... [+ 1].
struct SearchGrid {
  const std::uint8_t* descs = nullptr;  // 32 bytes per feature
  const std::int16_t* us = nullptr;
  const std::int16_t* vs = nullptr;
  const int* bin_begin = nullptr;
  int size = 0;  // features (descriptors readable at indices [0, size))
  int bins_u = 0, bins_v = 0;
  int bin_size = 1;             // pixels per bin (< 2^16)
  int width = 0, height = 0;    // pixels
  std::uint64_t bin_recip = 0;  // floor(2^32 / bin_size) + 1: x / bin_size == x * bin_recip >> 32
};
/// bin_recip for a bin size in [1, 2^16).
inline std::uint64_t binReciprocal(int bin_size) {
  return (std::uint64_t{1} << 32) / static_cast<std::uint64_t>(bin_size) + 1;
}

/// x / bin_size for 0 <= x < 2^16 (exact: the error of x * recip / 2^32 is below 1 / bin_size).
inline int binIndex(int x, std::uint64_t bin_recip) {
  return static_cast<int>((static_cast<std::uint64_t>(x) * bin_recip) >> 32);
}

/// searchBest over the features of class `cls` of every bin overlapping the window
/// [u0, u1] x [v0, v1] (clipped to the image): lowest SAD, lowest index on ties, second = lowest
/// cost of the others. *best_index = -1 and costs UINT32_MAX when nothing lies inside.
void searchWindow(const std::uint8_t* query, const SearchGrid& grid, int cls, int u0, int u1,
                  int v0, int v1, int* best_index, std::uint32_t* best_cost,
                  std::uint32_t* second_cost);

/// Patches of the Lucas-Kanade step (track_refine.hpp) are stored as rows of kLkStride floats;
/// patch sides up to kLkStride - 1 pixels (half widths up to kLkMaxHalf).
constexpr int kLkStride = 16;
constexpr int kLkMaxHalf = 7;

/// An 8-bit grey image (row-major, row stride in bytes).
struct GreyImage {
  const std::uint8_t* data = nullptr;
  int width = 0, height = 0, stride = 0;
};

/// The Lucas-Kanade step of one track (TrackStepRefiner::refine): translation-only, inverse
/// compositional, brightness-offset compensated alignment of the (2 half + 1)^2 patch of `prev`
/// around (x_prev, y_prev) with `cur`, starting at (*x, *y). `weight`: 2 half + 1 rows of kLkStride
/// Gaussian weights, zero past column 2 half; weight_sum their sum. True, with *x, *y moved, when
/// the step converges (last update under 0.03 px) within max_iterations and max_shift of the
/// start; false (*x, *y unspecified) when a patch leaves an image, the weighted gradient is below
/// min_gradient along some axis, or it does not converge.
bool alignPatchTranslation(const GreyImage& prev, double x_prev, double y_prev,
                           const GreyImage& cur, const float* weight, float weight_sum, int half,
                           int max_iterations, double max_shift, double min_gradient, double* x,
                           double* y);

}  // namespace ovo::frontend::kernels
