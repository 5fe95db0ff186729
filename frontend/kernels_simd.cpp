// Kernels of kernels.hpp. Written as simple row loops over int16 row buffers so that the compiler
// vectorises them for the native ISA (this file gets OVO_KERNEL_FLAGS); descriptor costs use
// SSE2 / AVX2 SAD instructions.
#include <immintrin.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "frontend/kernels.hpp"

namespace ovo::frontend::kernels {
namespace {

inline std::uint8_t saturateToByte(int x) {
  return static_cast<std::uint8_t>(x < 0 ? 0 : (x > 255 ? 255 : x));
}

inline std::uint32_t sadInline(const std::uint8_t* a, const std::uint8_t* b) {
#if defined(__AVX2__)
  const __m256i s = _mm256_sad_epu8(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(a)),
                                    _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b)));
  const __m128i h = _mm_add_epi64(_mm256_castsi256_si128(s), _mm256_extracti128_si256(s, 1));
  return static_cast<std::uint32_t>(_mm_cvtsi128_si32(h) + _mm_extract_epi32(h, 2));
#else
  const __m128i s0 = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)),
                                  _mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  const __m128i s1 = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a + 16)),
                                  _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 16)));
  const __m128i s = _mm_add_epi64(s0, s1);
  return static_cast<std::uint32_t>(_mm_cvtsi128_si32(s) +
                                    _mm_cvtsi128_si32(_mm_unpackhi_epi64(s, s)));
#endif
}

// Per-thread row buffers, reused across calls.
struct RowBuffers {
  std::vector<std::int16_t> a, b;
  void resize(int width) {
    if (static_cast<int>(a.size()) < width) {
      a.resize(width);
      b.resize(width);
    }
  }
};
thread_local RowBuffers t_rows;

}  // namespace

void sobel5x5(const std::uint8_t* img, int width, int height, int stride, std::uint8_t* du,
              std::uint8_t* dv) {
  std::memset(du, 128, static_cast<std::size_t>(width) * height);
  std::memset(dv, 128, static_cast<std::size_t>(width) * height);
  if (width < 5 || height < 5) return;
  t_rows.resize(width);
  std::int16_t* smooth = t_rows.a.data();  // [1 4 6 4 1] down the column
  std::int16_t* deriv = t_rows.b.data();   // [-1 -2 0 2 1] down the column
  for (int v = 2; v < height - 2; ++v) {
    const std::uint8_t* r0 = img + static_cast<std::ptrdiff_t>(v - 2) * stride;
    const std::uint8_t* r1 = r0 + stride;
    const std::uint8_t* r2 = r1 + stride;
    const std::uint8_t* r3 = r2 + stride;
    const std::uint8_t* r4 = r3 + stride;
    for (int u = 0; u < width; ++u) {
      smooth[u] = static_cast<std::int16_t>(r0[u] + 4 * r1[u] + 6 * r2[u] + 4 * r3[u] + r4[u]);
      deriv[u] = static_cast<std::int16_t>(-r0[u] - 2 * r1[u] + 2 * r3[u] + r4[u]);
    }
    std::uint8_t* du_row = du + static_cast<std::ptrdiff_t>(v) * width;
    std::uint8_t* dv_row = dv + static_cast<std::ptrdiff_t>(v) * width;
    for (int u = 2; u < width - 2; ++u) {
      const int gu = -smooth[u - 2] - 2 * smooth[u - 1] + 2 * smooth[u + 1] + smooth[u + 2];
      const int gv =
          deriv[u - 2] + 4 * deriv[u - 1] + 6 * deriv[u] + 4 * deriv[u + 1] + deriv[u + 2];
      du_row[u] = saturateToByte((gu >> 7) + 128);
      dv_row[u] = saturateToByte((gv >> 7) + 128);
    }
  }
}

void blobCorner5x5(const std::uint8_t* img, int width, int height, int stride, std::int16_t* blob,
                   std::int16_t* corner) {
  std::memset(blob, 0, sizeof(std::int16_t) * width * height);
  std::memset(corner, 0, sizeof(std::int16_t) * width * height);
  if (width < 5 || height < 5) return;
  t_rows.resize(width);
  std::int16_t* col3 = t_rows.a.data();  // rows v-1..v+1 summed; then [1 1 0 -1 -1] down
  std::int16_t* col5 = t_rows.b.data();  // rows v-2..v+2 summed
  for (int v = 2; v < height - 2; ++v) {
    const std::uint8_t* r0 = img + static_cast<std::ptrdiff_t>(v - 2) * stride;
    const std::uint8_t* r1 = r0 + stride;
    const std::uint8_t* r2 = r1 + stride;
    const std::uint8_t* r3 = r2 + stride;
    const std::uint8_t* r4 = r3 + stride;
    std::int16_t* blob_row = blob + static_cast<std::ptrdiff_t>(v) * width;
    std::int16_t* corner_row = corner + static_cast<std::ptrdiff_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      col3[u] = static_cast<std::int16_t>(r1[u] + r2[u] + r3[u]);
      col5[u] = static_cast<std::int16_t>(col3[u] + r0[u] + r4[u]);
    }
    // blob = 2 box3 - box5 + 7 centre (outer ring -1, inner ring +1, centre +8).
    for (int u = 2; u < width - 2; ++u) {
      const int box3 = col3[u - 1] + col3[u] + col3[u + 1];
      const int box5 = col5[u - 2] + col5[u - 1] + col5[u] + col5[u + 1] + col5[u + 2];
      blob_row[u] = static_cast<std::int16_t>(2 * box3 - box5 + 7 * r2[u]);
    }
    // checkerboard = b(row) a(col) with b = [1 1 0 -1 -1], a = [-1 -1 0 1 1].
    for (int u = 0; u < width; ++u)
      col3[u] = static_cast<std::int16_t>(r0[u] + r1[u] - r3[u] - r4[u]);
    for (int u = 2; u < width - 2; ++u) {
      corner_row[u] =
          static_cast<std::int16_t>(-col3[u - 2] - col3[u - 1] + col3[u + 1] + col3[u + 2]);
    }
  }
}

void halfResolution(const std::uint8_t* img, int width, int height, int stride, std::uint8_t* out) {
  const int w2 = width / 2;
  const int h2 = height / 2;
  for (int r = 0; r < h2; ++r) {
    const std::uint8_t* a = img + static_cast<std::ptrdiff_t>(2 * r) * stride;
    const std::uint8_t* b = a + stride;
    std::uint8_t* o = out + static_cast<std::ptrdiff_t>(r) * w2;
    for (int c = 0; c < w2; ++c) {
      o[c] =
          static_cast<std::uint8_t>((a[2 * c] + a[2 * c + 1] + b[2 * c] + b[2 * c + 1] + 2) >> 2);
    }
  }
}

bool isExtremum(const std::int16_t* response, int width, int height, int u, int v, int radius,
                bool is_max) {
  const int value = response[static_cast<std::ptrdiff_t>(v) * width + u];
  const int v0 = std::max(0, v - radius), v1 = std::min(height - 1, v + radius);
  const int u0 = std::max(0, u - radius), u1 = std::min(width - 1, u + radius);
  for (int v2 = v0; v2 <= v1; ++v2) {
    const std::int16_t* row = response + static_cast<std::ptrdiff_t>(v2) * width;
    for (int u2 = u0; u2 <= u1; ++u2) {
      const int x = row[u2];
      const bool earlier = v2 < v || (v2 == v && u2 < u);
      if (is_max ? (x > value || (x == value && earlier))
                 : (x < value || (x == value && earlier))) {
        return false;
      }
    }
  }
  return true;
}

void nonMaximumSuppression(const std::int16_t* blob, const std::int16_t* corner, int width,
                           int height, int n, int tau, int margin, std::vector<RawFeature>* out) {
  out->clear();
  const int step = n + 1;
  const int u_end = width - margin;  // exclusive
  const int v_end = height - margin;
  for (int bv = margin; bv < v_end; bv += step) {
    const int bv_end = std::min(bv + step, v_end);
    for (int bu = margin; bu < u_end; bu += step) {
      const int bu_end = std::min(bu + step, u_end);
      int blob_max = -32768, blob_min = 32767, corner_max = -32768, corner_min = 32767;
      int bmax_i = 0, bmin_i = 0, cmax_i = 0, cmin_i = 0;
      for (int v = bv; v < bv_end; ++v) {
        const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * width;
        for (int u = bu; u < bu_end; ++u) {
          const int i = static_cast<int>(row + u);
          const int b = blob[i], c = corner[i];
          if (b > blob_max) blob_max = b, bmax_i = i;
          if (b < blob_min) blob_min = b, bmin_i = i;
          if (c > corner_max) corner_max = c, cmax_i = i;
          if (c < corner_min) corner_min = c, cmin_i = i;
        }
      }
      const auto consider = [&](const std::int16_t* response, int index, int value, bool is_max,
                                std::uint8_t cls) {
        if (is_max ? value < tau : value > -tau) return;
        const int u = index % width, v = index / width;
        if (!isExtremum(response, width, height, u, v, n, is_max)) return;
        out->push_back({static_cast<std::int16_t>(u), static_cast<std::int16_t>(v),
                        static_cast<std::int16_t>(value), cls});
      };
      consider(blob, bmin_i, blob_min, false, 0);
      consider(blob, bmax_i, blob_max, true, 1);
      consider(corner, cmin_i, corner_min, false, 2);
      consider(corner, cmax_i, corner_max, true, 3);
    }
  }
}

std::uint32_t sad32(const std::uint8_t* a, const std::uint8_t* b) { return sadInline(a, b); }

std::uint32_t ssd32(const std::uint8_t* a, const std::uint8_t* b) {
  std::uint32_t sum = 0;
  for (int k = 0; k < kDescriptorBytes; ++k) {
    const int d = static_cast<int>(a[k]) - static_cast<int>(b[k]);
    sum += static_cast<std::uint32_t>(d * d);
  }
  return sum;
}

void searchBest(const std::uint8_t* query, const std::uint8_t* descs, const std::int16_t* us,
                const std::int16_t* vs, int begin, int end, int u0, int u1, int v0, int v1,
                int* best_index, std::uint32_t* best_cost, std::uint32_t* second_cost) {
  int index = *best_index;
  std::uint32_t cost = *best_cost;
  std::uint32_t second = *second_cost;
  for (int i = begin; i < end; ++i) {
    if (us[i] < u0 || us[i] > u1 || vs[i] < v0 || vs[i] > v1) continue;
    const std::uint32_t c =
        sadInline(query, descs + static_cast<std::ptrdiff_t>(i) * kDescriptorBytes);
    if (c < cost) {
      second = cost;
      cost = c;
      index = i;
    } else if (c < second) {
      second = c;
    }
  }
  *best_index = index;
  *best_cost = cost;
  *second_cost = second;
}

}  // namespace ovo::frontend::kernels
