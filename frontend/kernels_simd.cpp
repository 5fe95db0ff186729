// Kernels of kernels.hpp. Written as simple row loops over int16 row buffers so that the compiler
// vectorises them for the native ISA (this file gets OVO_KERNEL_FLAGS); descriptor costs use
// SSE2 / AVX2 / AVX-512 SAD instructions on x86, NEON on arm64 and plain loops elsewhere (all
// integer: the same answers on every path), and AVX-512 paths where noted.
#if defined(__SSE2__)
// GCC 12 warns inside its own AVX-512 headers (the _mm512_undefined_* placeholders of unmasked
// intrinsics, GCC bug 105593); the warnings point at the header, so silence them there.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#elif defined(__ARM_NEON)
#include <arm_neon.h>
#endif

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
#elif defined(__SSE2__)
  const __m128i s0 = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)),
                                  _mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  const __m128i s1 = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a + 16)),
                                  _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 16)));
  const __m128i s = _mm_add_epi64(s0, s1);
  return static_cast<std::uint32_t>(_mm_cvtsi128_si32(s) +
                                    _mm_cvtsi128_si32(_mm_unpackhi_epi64(s, s)));
#elif defined(__ARM_NEON)
  // |a - b| per byte, pairwise widened to 16 bit (at most 2 * 255 a lane per half), summed.
  const uint16x8_t s0 = vpaddlq_u8(vabdq_u8(vld1q_u8(a), vld1q_u8(b)));
  const uint16x8_t s1 = vpaddlq_u8(vabdq_u8(vld1q_u8(a + 16), vld1q_u8(b + 16)));
  return vaddlvq_u16(vaddq_u16(s0, s1));
#else
  std::uint32_t s = 0;
  for (int k = 0; k < kDescriptorBytes; ++k) s += static_cast<std::uint32_t>(std::abs(a[k] - b[k]));
  return s;
#endif
}

#if defined(__AVX512BW__)
// Candidates inside the window (of 16) from which searchWindow computes all 16 SADs at once.
constexpr int kMinVectorSad = 4;
// searchWindow: in windows of at least this area (px^2, e.g. the sparse pass's full windows) every
// group of 16 with a candidate inside gets the 16 SADs at once (fewer mispredicted branches); in
// the dense pass's small windows, few candidates are scored one by one.
constexpr int kLargeWindowArea = 4096;

// SADs of the 16 consecutive 32-byte descriptors at descs against the query held twice in
// query2, lane k for descriptor k. vpsadbw leaves four partial sums per descriptor (one per 8
// bytes); they are added within 128-bit lanes, then across the two lanes of each descriptor.
inline __m512i sad16(const __m512i query2, const std::uint8_t* descs) {
  __m512i total[4];
  for (int g = 0; g < 4; ++g) {
    // Descriptors 4g .. 4g + 3: a holds 4g, 4g + 1, b holds 4g + 2, 4g + 3.
    const std::uint8_t* d = descs + 128 * g;
    const __m512i a = _mm512_sad_epu8(_mm512_loadu_si512(d), query2);
    const __m512i b = _mm512_sad_epu8(_mm512_loadu_si512(d + 64), query2);
    // Each qword of a, b is below 2^16: pair them as dwords (a low, b high) and sum.
    const __m512i ab = _mm512_or_si512(a, _mm512_slli_epi64(b, 32));
    const __m512i s2 = _mm512_add_epi32(ab, _mm512_shuffle_epi32(ab, _MM_PERM_BADC));
    // dword 0: 4g, 1: 4g + 2 (lane 0); dword 8: 4g + 1, 9: 4g + 3 (lane 2).
    total[g] = _mm512_add_epi32(s2, _mm512_shuffle_i64x2(s2, s2, _MM_SHUFFLE(2, 3, 0, 1)));
  }
  const __m512i pick = _mm512_setr_epi32(0, 8, 1, 9, 16, 24, 17, 25, 0, 8, 1, 9, 16, 24, 17, 25);
  const __m512i lo = _mm512_permutex2var_epi32(total[0], pick, total[1]);  // 0..7 in dwords 0..7
  const __m512i hi = _mm512_permutex2var_epi32(total[2], pick, total[3]);  // 8..15
  return _mm512_inserti64x4(lo, _mm512_castsi512_si256(hi), 1);
}
#endif

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
    int u = 2;
#if defined(__AVX512BW__)
    // 32 columns at a time in int16: |gu| <= 6 * 16 * 255 / 2 and |gv| <= 16 * 6 * 255 fit.
    const __m512i offset = _mm512_set1_epi16(128), zero = _mm512_setzero_si512();
    const auto at = [](const std::int16_t* row, int i) { return _mm512_loadu_si512(row + i); };
    for (; u + 32 <= width - 2; u += 32) {
      const __m512i gu = _mm512_sub_epi16(
          _mm512_add_epi16(at(smooth, u + 2), _mm512_slli_epi16(at(smooth, u + 1), 1)),
          _mm512_add_epi16(at(smooth, u - 2), _mm512_slli_epi16(at(smooth, u - 1), 1)));
      const __m512i d0 = at(deriv, u);
      const __m512i gv = _mm512_add_epi16(
          _mm512_add_epi16(
              _mm512_add_epi16(at(deriv, u - 2), at(deriv, u + 2)),
              _mm512_slli_epi16(_mm512_add_epi16(at(deriv, u - 1), at(deriv, u + 1)), 2)),
          _mm512_add_epi16(_mm512_slli_epi16(d0, 2), _mm512_slli_epi16(d0, 1)));
      const __m512i bu = _mm512_max_epi16(_mm512_add_epi16(_mm512_srai_epi16(gu, 7), offset), zero);
      const __m512i bv = _mm512_max_epi16(_mm512_add_epi16(_mm512_srai_epi16(gv, 7), offset), zero);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(du_row + u), _mm512_cvtusepi16_epi8(bu));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(dv_row + u), _mm512_cvtusepi16_epi8(bv));
    }
#endif
    for (; u < width - 2; ++u) {
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

namespace {

template <bool kMax>
inline std::int16_t pick(std::int16_t a, std::int16_t b) {
  return kMax ? std::max(a, b) : std::min(a, b);
}

// Vertical then horizontal pass; interior columns in loops the compiler vectorises.
template <bool kMax>
void extremumFilterT(const std::int16_t* in, int width, int height, int r, std::int16_t* out) {
  t_rows.resize(width);
  std::int16_t* t = t_rows.a.data();
  for (int v = 0; v < height; ++v) {
    const int v0 = std::max(0, v - r), v1 = std::min(height - 1, v + r);
    std::memcpy(t, in + static_cast<std::ptrdiff_t>(v0) * width, sizeof(std::int16_t) * width);
    for (int v2 = v0 + 1; v2 <= v1; ++v2) {
      const std::int16_t* row = in + static_cast<std::ptrdiff_t>(v2) * width;
      for (int u = 0; u < width; ++u) t[u] = pick<kMax>(t[u], row[u]);
    }
    std::int16_t* o = out + static_cast<std::ptrdiff_t>(v) * width;
    const int lo = std::min(r, width), hi = std::max(lo, width - r);  // interior [lo, hi)
    for (int u = lo; u < hi; ++u) o[u] = t[u - r];
    for (int k = -r + 1; k <= r; ++k) {
      for (int u = lo; u < hi; ++u) o[u] = pick<kMax>(o[u], t[u + k]);
    }
    const auto clipped = [&](int u) {
      std::int16_t m = t[std::max(0, u - r)];
      for (int u2 = std::max(0, u - r) + 1; u2 <= std::min(width - 1, u + r); ++u2) {
        m = pick<kMax>(m, t[u2]);
      }
      o[u] = m;
    };
    for (int u = 0; u < lo; ++u) clipped(u);
    for (int u = hi; u < width; ++u) clipped(u);
  }
}

#if defined(__AVX512BW__)
// The min and the max filter of extremumFilterT in one pass over the input, 32 columns at a time
// with the window's rows (then columns) folded in registers.
void extremumPair512(const std::int16_t* in, int width, int height, int r, std::int16_t* out_min,
                     std::int16_t* out_max) {
  t_rows.resize(width);
  std::int16_t* t_min = t_rows.a.data();
  std::int16_t* t_max = t_rows.b.data();
  const auto lanes = [](int n) { return n >= 32 ? ~__mmask32{0} : (__mmask32{1} << n) - 1; };
  for (int v = 0; v < height; ++v) {
    const int v0 = std::max(0, v - r), v1 = std::min(height - 1, v + r);
    for (int u = 0; u < width; u += 32) {
      const __mmask32 m = lanes(width - u);
      __m512i lo = _mm512_maskz_loadu_epi16(m, in + static_cast<std::ptrdiff_t>(v0) * width + u);
      __m512i hi = lo;
      for (int v2 = v0 + 1; v2 <= v1; ++v2) {
        const __m512i x =
            _mm512_maskz_loadu_epi16(m, in + static_cast<std::ptrdiff_t>(v2) * width + u);
        lo = _mm512_min_epi16(lo, x);
        hi = _mm512_max_epi16(hi, x);
      }
      _mm512_mask_storeu_epi16(t_min + u, m, lo);
      _mm512_mask_storeu_epi16(t_max + u, m, hi);
    }
    std::int16_t* o_min = out_min + static_cast<std::ptrdiff_t>(v) * width;
    std::int16_t* o_max = out_max + static_cast<std::ptrdiff_t>(v) * width;
    const int lo_u = std::min(r, width), hi_u = std::max(lo_u, width - r);  // interior [lo, hi)
    for (int u = lo_u; u < hi_u; u += 32) {
      const __mmask32 m = lanes(hi_u - u);
      __m512i lo = _mm512_maskz_loadu_epi16(m, t_min + u - r);
      __m512i hi = _mm512_maskz_loadu_epi16(m, t_max + u - r);
      for (int k = -r + 1; k <= r; ++k) {
        lo = _mm512_min_epi16(lo, _mm512_maskz_loadu_epi16(m, t_min + u + k));
        hi = _mm512_max_epi16(hi, _mm512_maskz_loadu_epi16(m, t_max + u + k));
      }
      _mm512_mask_storeu_epi16(o_min + u, m, lo);
      _mm512_mask_storeu_epi16(o_max + u, m, hi);
    }
    const auto clipped = [&](int u) {
      const int u0 = std::max(0, u - r), u1 = std::min(width - 1, u + r);
      std::int16_t a = t_min[u0], b = t_max[u0];
      for (int u2 = u0 + 1; u2 <= u1; ++u2) {
        a = std::min(a, t_min[u2]);
        b = std::max(b, t_max[u2]);
      }
      o_min[u] = a;
      o_max[u] = b;
    };
    for (int u = 0; u < lo_u; ++u) clipped(u);
    for (int u = hi_u; u < width; ++u) clipped(u);
  }
}
#endif

// Min (out_min) and max (out_max) over the (2 r + 1)^2 window clipped to the image.
void extremumPair(const std::int16_t* in, int width, int height, int r, std::int16_t* out_min,
                  std::int16_t* out_max) {
#if defined(__AVX512BW__)
  extremumPair512(in, width, height, r, out_min, out_max);
#else
  extremumFilterT<false>(in, width, height, r, out_min);
  extremumFilterT<true>(in, width, height, r, out_max);
#endif
}

// True when a pixel before (u, v) in raster order within the (2 r + 1)^2 window has `value`.
bool earlierEqual(const std::int16_t* response, int width, int u, int v, int r, int value) {
  const int u0 = std::max(0, u - r), u1 = std::min(width - 1, u + r);
#if defined(__AVX512BW__)
  const __m512i target = _mm512_set1_epi16(static_cast<std::int16_t>(value));
#endif
  for (int v2 = std::max(0, v - r); v2 <= v; ++v2) {
    const std::int16_t* row = response + static_cast<std::ptrdiff_t>(v2) * width;
    const int end = v2 == v ? u - 1 : u1;
#if defined(__AVX512BW__)
    for (int u2 = u0; u2 <= end; u2 += 32) {
      const int n = std::min(32, end - u2 + 1);
      const __mmask32 lanes = n == 32 ? ~__mmask32{0} : (__mmask32{1} << n) - 1;
      if (_mm512_mask_cmpeq_epi16_mask(lanes, _mm512_maskz_loadu_epi16(lanes, row + u2), target)) {
        return true;
      }
    }
#else
    for (int u2 = u0; u2 <= end; ++u2) {
      if (row[u2] == value) return true;
    }
#endif
  }
  return false;
}

thread_local std::vector<std::int16_t> t_extrema[4];
#if !defined(__AVX512BW__)
thread_local std::vector<std::uint8_t> t_flags;
#endif

}  // namespace

void extremumFilter(const std::int16_t* in, int width, int height, int r, bool is_max,
                    std::int16_t* out) {
  if (is_max) {
    extremumFilterT<true>(in, width, height, r, out);
  } else {
    extremumFilterT<false>(in, width, height, r, out);
  }
}

void nonMaximumSuppression(const std::int16_t* blob, const std::int16_t* corner, int width,
                           int height, int n, int n_sparse, int tau, int margin,
                           std::vector<RawFeature>* out) {
  out->clear();
  const std::size_t size = static_cast<std::size_t>(width) * height;
  const std::int16_t* response[4] = {blob, blob, corner, corner};
  const std::int16_t* extremum[4];
  for (int c = 0; c < 4; ++c) {
    t_extrema[c].resize(size);
    extremum[c] = t_extrema[c].data();
  }
  extremumPair(blob, width, height, n, t_extrema[0].data(), t_extrema[1].data());
  extremumPair(corner, width, height, n, t_extrema[2].data(), t_extrema[3].data());
  // The (2 n_sparse + 1)^2 extremum is that of the (2n + 1)^2 windows centred at the offsets
  // {-s, 0, s}^2 with s = n_sparse - n, when these windows cover it (n_sparse <= 3n + 1).
  const int s = n_sparse - n;
  const bool sparse_from_filter = s >= 0 && n_sparse <= 3 * n + 1;
  const auto isSparse = [&](int c, int u, int v, int value) {
    const bool is_max = (c & 1) != 0;
    if (!sparse_from_filter) {
      return isExtremum(response[c], width, height, u, v, n_sparse, is_max);
    }
    for (const int dv : {-s, 0, s}) {
      const int v2 = std::clamp(v + dv, 0, height - 1);
      for (const int du : {-s, 0, s}) {
        const int u2 = std::clamp(u + du, 0, width - 1);
        const int m = extremum[c][static_cast<std::ptrdiff_t>(v2) * width + u2];
        if (is_max ? m > value : m < value) return false;
      }
    }
    return !earlierEqual(response[c], width, u, v, n_sparse, value);
  };
  const int u_end = width - margin, v_end = height - margin;  // exclusive
  if (u_end <= margin) return;
  const auto emit = [&](int cls, int u, int v, std::ptrdiff_t row) {
    const int value = response[cls][row + u];
    if (earlierEqual(response[cls], width, u, v, n, value)) return;
    out->push_back({static_cast<std::int16_t>(u), static_cast<std::int16_t>(v),
                    static_cast<std::int16_t>(value), static_cast<std::uint8_t>(cls),
                    static_cast<std::uint8_t>(isSparse(cls, u, v, value))});
  };
#if defined(__AVX512BW__)
  // 32 pixels at a time: one bit mask per class, then the set pixels in raster order.
  const __m512i neg_tau = _mm512_set1_epi16(static_cast<std::int16_t>(-tau));
  const __m512i pos_tau = _mm512_set1_epi16(static_cast<std::int16_t>(tau));
  for (int v = margin; v < v_end; ++v) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * width;
    for (int u0 = margin; u0 < u_end; u0 += 32) {
      const int count = std::min(32, u_end - u0);
      const __mmask32 lanes = count == 32 ? ~__mmask32{0} : (__mmask32{1} << count) - 1;
      const auto load = [&](const std::int16_t* plane) {
        return _mm512_maskz_loadu_epi16(lanes, plane + row + u0);
      };
      const __m512i b = load(blob), c = load(corner);
      const __mmask32 cls_mask[4] = {
          _mm512_mask_cmpeq_epi16_mask(_mm512_cmple_epi16_mask(b, neg_tau) & lanes, b,
                                       load(extremum[0])),
          _mm512_mask_cmpeq_epi16_mask(_mm512_cmpge_epi16_mask(b, pos_tau) & lanes, b,
                                       load(extremum[1])),
          _mm512_mask_cmpeq_epi16_mask(_mm512_cmple_epi16_mask(c, neg_tau) & lanes, c,
                                       load(extremum[2])),
          _mm512_mask_cmpeq_epi16_mask(_mm512_cmpge_epi16_mask(c, pos_tau) & lanes, c,
                                       load(extremum[3]))};
      std::uint32_t any = cls_mask[0] | cls_mask[1] | cls_mask[2] | cls_mask[3];
      while (any) {
        const int bit = __builtin_ctz(any);
        any &= any - 1;
        for (int cls = 0; cls < 4; ++cls) {
          if ((cls_mask[cls] >> bit) & 1u) emit(cls, u0 + bit, v, row);
        }
      }
    }
  }
#else
  t_flags.resize(width);
  std::uint8_t* flags = t_flags.data();
  for (int v = margin; v < v_end; ++v) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * width;
    const std::int16_t *b = blob + row, *c = corner + row;
    const std::int16_t *b_min = extremum[0] + row, *b_max = extremum[1] + row;
    const std::int16_t *c_min = extremum[2] + row, *c_max = extremum[3] + row;
    for (int u = margin; u < u_end; ++u) {
      flags[u] = static_cast<std::uint8_t>(((b[u] == b_min[u]) & (b[u] <= -tau)) |
                                           (((b[u] == b_max[u]) & (b[u] >= tau)) << 1) |
                                           (((c[u] == c_min[u]) & (c[u] <= -tau)) << 2) |
                                           (((c[u] == c_max[u]) & (c[u] >= tau)) << 3));
    }
    for (int u = margin; u < u_end; ++u) {
      // Skip eight flag-free pixels at once (candidates are sparse).
      if (u + 8 <= u_end) {
        std::uint64_t word;
        std::memcpy(&word, flags + u, 8);
        if (word == 0) {
          u += 7;
          continue;
        }
      }
      for (int cls = 0; cls < 4; ++cls) {
        if (flags[u] & (1 << cls)) emit(cls, u, v, row);
      }
    }
  }
#endif
}

std::uint32_t sad32(const std::uint8_t* a, const std::uint8_t* b) { return sadInline(a, b); }

void describe(const std::uint8_t* du, const std::uint8_t* dv, int width, int u, int v,
              std::uint8_t* out) {
  const std::ptrdiff_t centre = static_cast<std::ptrdiff_t>(v) * width + u;
  for (int k = 0; k < 16; ++k) {
    const std::ptrdiff_t i =
        centre + static_cast<std::ptrdiff_t>(kPatternDv[k]) * width + kPatternDu[k];
    out[2 * k] = du[i];
    out[2 * k + 1] = dv[i];
  }
}

#if defined(__AVX512BW__)
namespace {

// The rows of the 13 x 13 patch around a refinement position: patch row R (image row v - 6 + R)
// as 16 (du, dv) int16 pairs for the columns u - 6 .. u + 9 (the last three unused, zero).
inline void loadPatchRows(const std::uint8_t* du, const std::uint8_t* dv, int width, int u, int v,
                          __m512i* rows) {
  const __mmask16 cols = 0x1fff;  // 13 bytes: no read beyond u + 6
  for (int r = 0; r < 13; ++r) {
    const std::ptrdiff_t i = static_cast<std::ptrdiff_t>(v - 6 + r) * width + u - 6;
    const __m128i a = _mm_maskz_loadu_epi8(cols, du + i), b = _mm_maskz_loadu_epi8(cols, dv + i);
    rows[r] =
        _mm512_cvtepu8_epi16(_mm256_set_m128i(_mm_unpackhi_epi8(a, b), _mm_unpacklo_epi8(a, b)));
  }
}

constexpr bool patternFitsSevenColumns() {
  for (int k = 0; k < 16; ++k) {
    const int du = kPatternDu[k], dv = kPatternDv[k];
    if (du != -5 && du != -3 && du != -1 && du != 0 && du != 1 && du != 3 && du != 5) return false;
    if (dv < -5 || dv > 5) return false;
  }
  return true;
}
static_assert(patternFitsSevenColumns(), "ssdAround's column groups miss a descriptor sample");

// Adds the SSD terms of the samples with column offset kDu to total[row] (lane c for the block
// column c - 1): per block row, madd of the (du, dv) differences gives one dword per patch column;
// the group's sum is shifted down by kDu + 5 lanes to bring column u + kDu - 1 to lane 0.
template <int kDu>
inline void addSampleColumn(const __m512i* rows, const __m512i ref_pairs, __m512i* total) {
  __m512i sum[3] = {_mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512()};
#pragma GCC unroll 16
  for (int k = 0; k < 16; ++k) {
    if (kPatternDu[k] != kDu) continue;
    const __m512i pair = _mm512_permutexvar_epi32(_mm512_set1_epi32(k), ref_pairs);
    for (int row = 0; row < 3; ++row) {
      const __m512i d = _mm512_sub_epi16(rows[kPatternDv[k] + row + 5], pair);
      sum[row] = _mm512_add_epi32(sum[row], _mm512_madd_epi16(d, d));
    }
  }
  for (int row = 0; row < 3; ++row) {
    total[row] = _mm512_add_epi32(total[row],
                                  _mm512_alignr_epi32(_mm512_setzero_si512(), sum[row], kDu + 5));
  }
}

}  // namespace
#endif

void ssdAround(const std::uint8_t* du, const std::uint8_t* dv, int width, int u, int v,
               const std::uint8_t* ref, std::uint32_t* out) {
#if defined(__AVX512BW__)
  __m512i rows[13];
  loadPatchRows(du, dv, width, u, v, rows);
  // Dword k: the reference's (du, dv) pair of sample k as two int16.
  const __m512i ref_pairs =
      _mm512_cvtepu8_epi16(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(ref)));
  __m512i total[3] = {_mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512()};
  addSampleColumn<-5>(rows, ref_pairs, total);
  addSampleColumn<-3>(rows, ref_pairs, total);
  addSampleColumn<-1>(rows, ref_pairs, total);
  addSampleColumn<0>(rows, ref_pairs, total);
  addSampleColumn<1>(rows, ref_pairs, total);
  addSampleColumn<3>(rows, ref_pairs, total);
  addSampleColumn<5>(rows, ref_pairs, total);
  for (int row = 0; row < 3; ++row) {
    _mm_mask_storeu_epi32(out + 3 * row, 0x7, _mm512_castsi512_si128(total[row]));
  }
#elif defined(__SSE4_1__)
  // Per sample and row: the du / dv bytes of the three columns interleaved and widened to int16,
  // minus the reference pair, squared and pair-summed by madd: lane j holds column j - 1.
  __m128i acc[3] = {_mm_setzero_si128(), _mm_setzero_si128(), _mm_setzero_si128()};
  for (int k = 0; k < 16; ++k) {
    const __m128i r = _mm_set1_epi32(ref[2 * k] | (ref[2 * k + 1] << 16));
    const std::ptrdiff_t top =
        static_cast<std::ptrdiff_t>(v + kPatternDv[k] - 1) * width + u + kPatternDu[k] - 1;
    for (int row = 0; row < 3; ++row) {
      const std::ptrdiff_t i = top + static_cast<std::ptrdiff_t>(row) * width;
      std::int32_t a, b;
      std::memcpy(&a, du + i, 4);
      std::memcpy(&b, dv + i, 4);
      const __m128i x =
          _mm_cvtepu8_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(a), _mm_cvtsi32_si128(b)));
      const __m128i d = _mm_sub_epi16(x, r);
      acc[row] = _mm_add_epi32(acc[row], _mm_madd_epi16(d, d));
    }
  }
  for (int row = 0; row < 3; ++row) {
    alignas(16) std::uint32_t lanes[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(lanes), acc[row]);
    out[3 * row] = lanes[0];
    out[3 * row + 1] = lanes[1];
    out[3 * row + 2] = lanes[2];
  }
#else
  std::uint8_t d[kDescriptorBytes];
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) {
      describe(du, dv, width, u + col - 1, v + row - 1, d);
      out[3 * row + col] = ssd32(ref, d);
    }
  }
#endif
}

std::uint32_t ssd32(const std::uint8_t* a, const std::uint8_t* b) {
  // |a - b| as bytes, widened to 16 bit, squared and pairwise summed by madd.
#if defined(__AVX2__)
  const __m256i va = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a));
  const __m256i vb = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b));
  const __m256i d = _mm256_or_si256(_mm256_subs_epu8(va, vb), _mm256_subs_epu8(vb, va));
  const __m256i zero = _mm256_setzero_si256();
  const __m256i lo = _mm256_unpacklo_epi8(d, zero), hi = _mm256_unpackhi_epi8(d, zero);
  const __m256i s = _mm256_add_epi32(_mm256_madd_epi16(lo, lo), _mm256_madd_epi16(hi, hi));
  __m128i h = _mm_add_epi32(_mm256_castsi256_si128(s), _mm256_extracti128_si256(s, 1));
  h = _mm_add_epi32(h, _mm_shuffle_epi32(h, _MM_SHUFFLE(1, 0, 3, 2)));
  h = _mm_add_epi32(h, _mm_shuffle_epi32(h, _MM_SHUFFLE(2, 3, 0, 1)));
  return static_cast<std::uint32_t>(_mm_cvtsi128_si32(h));
#elif defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  __m128i h = zero;
  for (int k = 0; k < kDescriptorBytes; k += 16) {
    const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + k));
    const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + k));
    const __m128i d = _mm_or_si128(_mm_subs_epu8(va, vb), _mm_subs_epu8(vb, va));
    const __m128i lo = _mm_unpacklo_epi8(d, zero), hi = _mm_unpackhi_epi8(d, zero);
    h = _mm_add_epi32(h, _mm_add_epi32(_mm_madd_epi16(lo, lo), _mm_madd_epi16(hi, hi)));
  }
  h = _mm_add_epi32(h, _mm_shuffle_epi32(h, _MM_SHUFFLE(1, 0, 3, 2)));
  h = _mm_add_epi32(h, _mm_shuffle_epi32(h, _MM_SHUFFLE(2, 3, 0, 1)));
  return static_cast<std::uint32_t>(_mm_cvtsi128_si32(h));
#elif defined(__ARM_NEON)
  // |a - b| per byte, squared into 16 bit (at most 255^2), accumulated pairwise into 32 bit.
  uint32x4_t h = vdupq_n_u32(0);
  for (int k = 0; k < kDescriptorBytes; k += 16) {
    const uint8x16_t d = vabdq_u8(vld1q_u8(a + k), vld1q_u8(b + k));
    h = vpadalq_u16(h, vmull_u8(vget_low_u8(d), vget_low_u8(d)));
    h = vpadalq_u16(h, vmull_u8(vget_high_u8(d), vget_high_u8(d)));
  }
  return vaddvq_u32(h);
#else
  std::uint32_t s = 0;
  for (int k = 0; k < kDescriptorBytes; ++k) {
    const std::uint32_t d = static_cast<std::uint32_t>(std::abs(a[k] - b[k]));
    s += d * d;
  }
  return s;
#endif
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

#if defined(__AVX512BW__)
namespace {

// The lowest and second-lowest (cost << 32 | index) keys of a window's candidates: per lane of
// `lane1` / `lane2` for the SADs computed 16 at a time, and in `one1` / `one2` for candidates
// scored one by one; reduced once per window. A key orders by cost, then by index (the tie rule).
struct WindowMins {
  __m512i lane1 = _mm512_set1_epi64(-1), lane2 = _mm512_set1_epi64(-1);
  std::uint64_t one1 = ~std::uint64_t{0}, one2 = ~std::uint64_t{0};
  bool any_lanes = false;

  void add(std::uint64_t key) {  // without branches: their outcome is unpredictable
    one2 = std::min(one2, std::max(one1, key));
    one1 = std::min(one1, key);
  }
  void addLanes(__m512i keys) {
    const __m512i larger = _mm512_max_epu64(lane1, keys);
    lane1 = _mm512_min_epu64(lane1, keys);
    lane2 = _mm512_min_epu64(lane2, larger);
  }
  // Lowest and second-lowest key overall.
  void reduce(std::uint64_t* first, std::uint64_t* second) const {
    if (!any_lanes) {
      *first = one1;
      *second = one2;
      return;
    }
    const std::uint64_t m1 = _mm512_reduce_min_epu64(lane1);
    const __mmask8 at =
        _mm512_cmpeq_epu64_mask(lane1, _mm512_set1_epi64(static_cast<long long>(m1)));
    const std::uint64_t m2 = std::min(
        _mm512_reduce_min_epu64(lane2),
        _mm512_reduce_min_epu64(_mm512_mask_blend_epi64(at, lane1, _mm512_set1_epi64(-1))));
    if (m1 < one1) {
      *first = m1;
      *second = std::min(m2, one1);
    } else {
      *first = one1;
      *second = std::min(m1, one2);
    }
  }
};

// Adds the candidates i in [begin, end) inside [u0, u1] x [v0, v1] to *mins; descriptors are
// readable up to index `readable` (exclusive); groups of 16 with at least `min_vector` inside get
// their SADs at once.
inline __attribute__((always_inline)) void scanRange(const std::uint8_t* query,
                                                     const __m512i query2, const SearchGrid& grid,
                                                     int begin, int end, int readable,
                                                     int min_vector, const __m512i lo_u,
                                                     const __m512i hi_u, const __m512i lo_v,
                                                     const __m512i hi_v, WindowMins* mins) {
  const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int i = begin; i < end; i += 32) {
    const int n = std::min(32, end - i);
    const __mmask32 tail = n == 32 ? ~__mmask32{0} : (__mmask32{1} << n) - 1;
    const __m512i u = _mm512_maskz_loadu_epi16(tail, grid.us + i);
    const __m512i v = _mm512_maskz_loadu_epi16(tail, grid.vs + i);
    const std::uint32_t inside =
        _mm512_mask_cmpge_epi16_mask(tail, u, lo_u) & _mm512_cmple_epi16_mask(u, hi_u) &
        _mm512_cmpge_epi16_mask(v, lo_v) & _mm512_cmple_epi16_mask(v, hi_v);
    for (int half = 0; half < 2; ++half) {
      const int first = i + 16 * half;
      std::uint32_t bits = (inside >> (16 * half)) & 0xffffu;
      if (bits == 0) continue;
      if (first + 16 > readable || __builtin_popcount(bits) < min_vector) {
        while (bits) {
          const int k = first + __builtin_ctz(bits);
          bits &= bits - 1;
          const std::uint32_t c =
              sadInline(query, grid.descs + static_cast<std::ptrdiff_t>(k) * kDescriptorBytes);
          mins->add((std::uint64_t{c} << 32) | static_cast<std::uint32_t>(k));
        }
        continue;
      }
      // Outside lanes cost UINT32_MAX, which no SAD reaches. The (index, cost) dword pairs of
      // unpacklo / unpackhi are the keys of lanes {0, 1, 4, 5, ...} / {2, 3, 6, 7, ...}.
      const __m512i costs = _mm512_mask_blend_epi32(
          static_cast<__mmask16>(bits), _mm512_set1_epi32(-1),
          sad16(query2, grid.descs + static_cast<std::ptrdiff_t>(first) * kDescriptorBytes));
      const __m512i index = _mm512_add_epi32(_mm512_set1_epi32(first), iota);
      mins->addLanes(_mm512_unpacklo_epi32(index, costs));
      mins->addLanes(_mm512_unpackhi_epi32(index, costs));
      mins->any_lanes = true;
    }
  }
}

}  // namespace
#endif

void searchWindow(const std::uint8_t* query, const SearchGrid& grid, int cls, int u0, int u1,
                  int v0, int v1, int* best_index, std::uint32_t* best_cost,
                  std::uint32_t* second_cost) {
  *best_index = -1;
  *best_cost = ~std::uint32_t{0};
  *second_cost = ~std::uint32_t{0};
  u0 = std::max(u0, 0);
  u1 = std::min(u1, grid.width - 1);
  v0 = std::max(v0, 0);
  v1 = std::min(v1, grid.height - 1);
  if (u0 > u1 || v0 > v1) return;
  const auto binOf = [&](int x) { return binIndex(x, grid.bin_recip); };
  const int col0 = binOf(u0), col1 = std::min(binOf(u1), grid.bins_u - 1);
  const int row0 = binOf(v0), row1 = std::min(binOf(v1), grid.bins_v - 1);
#if defined(__AVX512BW__)
  const __m512i lo_u = _mm512_set1_epi16(static_cast<std::int16_t>(u0));
  const __m512i hi_u = _mm512_set1_epi16(static_cast<std::int16_t>(u1));
  const __m512i lo_v = _mm512_set1_epi16(static_cast<std::int16_t>(v0));
  const __m512i hi_v = _mm512_set1_epi16(static_cast<std::int16_t>(v1));
  const __m512i query2 =
      _mm512_broadcast_i64x4(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(query)));
  const int min_vector = (u1 - u0 + 1) * (v1 - v0 + 1) >= kLargeWindowArea ? 1 : kMinVectorSad;
  WindowMins mins;
  for (int row = row0; row <= row1; ++row) {
    const int* first = grid.bin_begin + (cls * grid.bins_v + row) * grid.bins_u;
    scanRange(query, query2, grid, first[col0], first[col1 + 1], grid.size, min_vector, lo_u, hi_u,
              lo_v, hi_v, &mins);
  }
  std::uint64_t first = 0, second = 0;
  mins.reduce(&first, &second);
  *best_cost = static_cast<std::uint32_t>(first >> 32);
  *second_cost = static_cast<std::uint32_t>(second >> 32);
  if (*best_cost != ~std::uint32_t{0}) *best_index = static_cast<int>(first & 0xffffffffu);
#else
  for (int row = row0; row <= row1; ++row) {
    const int* first = grid.bin_begin + (cls * grid.bins_v + row) * grid.bins_u;
    searchBest(query, grid.descs, grid.us, grid.vs, first[col0], first[col1 + 1], u0, u1, v0, v1,
               best_index, best_cost, second_cost);
  }
#endif
}

}  // namespace ovo::frontend::kernels
