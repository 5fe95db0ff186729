// The SIMD kernels against their plain definitions: the windowed best-SAD search (one bin range,
// and every bin a window overlaps), the bin index by reciprocal and the 3x3 SSD block of the
// sub-pixel refinement.
#include "frontend/kernels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "frontend/features.hpp"

namespace ovo::frontend {
namespace {

struct Best {
  int index = -1;
  std::uint32_t cost = std::numeric_limits<std::uint32_t>::max();
  std::uint32_t second = std::numeric_limits<std::uint32_t>::max();
};

// The definition: lowest SAD, lowest index on ties; second = lowest cost of the others.
Best bruteForce(const std::uint8_t* query, const std::vector<std::uint8_t>& descs,
                const std::vector<std::int16_t>& us, const std::vector<std::int16_t>& vs, int begin,
                int end, int u0, int u1, int v0, int v1) {
  Best b;
  std::vector<std::uint32_t> costs;
  for (int i = begin; i < end; ++i) {
    if (us[i] < u0 || us[i] > u1 || vs[i] < v0 || vs[i] > v1) continue;
    std::uint32_t c = 0;
    for (int k = 0; k < 32; ++k) c += std::abs(int(query[k]) - int(descs[32 * i + k]));
    if (c < b.cost) b.cost = c, b.index = i;
    costs.push_back(c);
  }
  bool skipped = false;
  for (const std::uint32_t c : costs) {
    if (c == b.cost && !skipped) {
      skipped = true;
      continue;
    }
    b.second = std::min(b.second, c);
  }
  return b;
}

TEST(Kernels, SearchBestEqualsTheBruteForceDefinition) {
  std::mt19937 rng(11);
  // Few distinct byte values make cost ties common, so the tie rule is exercised.
  std::uniform_int_distribution<int> byte(100, 104), coord(0, 99), len(0, 90);
  const int n = 400;
  std::vector<std::uint8_t> descs(32 * n);
  std::vector<std::int16_t> us(n), vs(n);
  for (auto& d : descs) d = static_cast<std::uint8_t>(byte(rng));
  for (int i = 0; i < n; ++i) us[i] = coord(rng), vs[i] = coord(rng);
  for (int trial = 0; trial < 2000; ++trial) {
    std::uint8_t query[32];
    for (auto& q : query) q = static_cast<std::uint8_t>(byte(rng));
    const int begin = coord(rng) * 3, end = std::min(n, begin + len(rng) * 2);
    // Windows from a few pixels (few candidates inside) to everything (all inside).
    const int half = trial % 3 == 0 ? 100 : 3 + trial % 40;
    const int cu = coord(rng), cv = coord(rng);
    const Best want =
        bruteForce(query, descs, us, vs, begin, end, cu - half, cu + half, cv - half, cv + half);
    Best got;
    kernels::searchBest(query, descs.data(), us.data(), vs.data(), begin, end, cu - half, cu + half,
                        cv - half, cv + half, &got.index, &got.cost, &got.second);
    ASSERT_EQ(got.index, want.index) << trial;
    ASSERT_EQ(got.cost, want.cost) << trial;
    ASSERT_EQ(got.second, want.second) << trial;
  }
}

TEST(Kernels, BinIndexEqualsIntegerDivision) {
  for (const int bin : {1, 2, 3, 7, 25, 49, 50, 51, 64, 100, 333, 1000, 9999, 10000, 65535}) {
    const std::uint64_t recip = kernels::binReciprocal(bin);
    for (int x = 0; x < (1 << 16); ++x) ASSERT_EQ(kernels::binIndex(x, recip), x / bin) << bin;
  }
}

// The SearchGrid over the given features (n = us.size()) of a width x height image.
kernels::SearchGrid gridOf(const std::vector<std::uint8_t>& descs,
                           const std::vector<std::int16_t>& us, const std::vector<std::int16_t>& vs,
                           const std::vector<int>& begin, int bins_u, int bins_v, int bin,
                           int width, int height) {
  kernels::SearchGrid grid;
  grid.descs = descs.data();
  grid.us = us.data();
  grid.vs = vs.data();
  grid.bin_begin = begin.data();
  grid.size = static_cast<int>(us.size());
  grid.bins_u = bins_u;
  grid.bins_v = bins_v;
  grid.bin_size = bin;
  grid.width = width;
  grid.height = height;
  grid.bin_recip = kernels::binReciprocal(bin);
  return grid;
}

TEST(Kernels, SearchWindowEqualsTheBruteForceSearchOverItsClass) {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> byte(100, 104), cls_of(0, 3), u_of(0, 219), v_of(0, 159);
  // Features of a 220 x 160 image on 50 px bins, ordered by (class, bin row, bin column).
  const int n = 600, bin = 50, bins_u = 5, bins_v = 4;
  struct Raw {
    int key, u, v;
  };
  std::vector<Raw> raw(n);
  for (auto& r : raw) {
    r.u = u_of(rng), r.v = v_of(rng);
    r.key = (cls_of(rng) * bins_v + r.v / bin) * bins_u + r.u / bin;
  }
  std::stable_sort(raw.begin(), raw.end(),
                   [](const Raw& a, const Raw& b) { return a.key < b.key; });
  std::vector<std::uint8_t> descs(32 * n);
  for (auto& d : descs) d = static_cast<std::uint8_t>(byte(rng));
  std::vector<std::int16_t> us(n), vs(n);
  std::vector<int> begin(4 * bins_u * bins_v + 1, n);
  for (int i = n - 1; i >= 0; --i) {
    us[i] = static_cast<std::int16_t>(raw[i].u);
    vs[i] = static_cast<std::int16_t>(raw[i].v);
    for (int k = 0; k <= raw[i].key; ++k) begin[k] = std::min(begin[k], i);
  }
  const kernels::SearchGrid grid = gridOf(descs, us, vs, begin, bins_u, bins_v, bin, 220, 160);
  std::uniform_int_distribution<int> centre_u(-20, 240), centre_v(-20, 180), half_of(0, 120);
  for (int trial = 0; trial < 2000; ++trial) {
    std::uint8_t query[32];
    for (auto& q : query) q = static_cast<std::uint8_t>(byte(rng));
    const int cls = trial % 4, cu = centre_u(rng), cv = centre_v(rng), half = half_of(rng);
    const int first = begin[cls * bins_u * bins_v], last = begin[(cls + 1) * bins_u * bins_v];
    const Best want =
        bruteForce(query, descs, us, vs, first, last, cu - half, cu + half, cv - half, cv + half);
    Best got;
    kernels::searchWindow(query, grid, cls, cu - half, cu + half, cv - half, cv + half, &got.index,
                          &got.cost, &got.second);
    ASSERT_EQ(got.index, want.index) << trial;
    ASSERT_EQ(got.cost, want.cost) << trial;
    ASSERT_EQ(got.second, want.second) << trial;
  }
}

// Equal descriptors: every candidate costs the same, so the best is the lowest index inside the
// window and the second-best cost equals the best (if two lie inside), for windows from one pixel
// (candidates scored one by one) to the whole image (16 SADs at once, reduced once per window).
TEST(Kernels, SearchWindowTakesTheLowestIndexAmongEqualCosts) {
  // A 3 px lattice of one class on a 120 x 90 image, 30 px bins: about 100 features per bin.
  const int width = 120, height = 90, bin = 30, bins_u = 4, bins_v = 3;
  std::vector<std::int16_t> us, vs;
  std::vector<int> begin(4 * bins_u * bins_v + 1, 0);
  for (int row = 0; row < bins_v; ++row) {
    for (int col = 0; col < bins_u; ++col) {
      begin[row * bins_u + col] = static_cast<int>(us.size());
      for (int v = row * bin; v < (row + 1) * bin; v += 3) {
        for (int u = col * bin; u < (col + 1) * bin; u += 3) {
          us.push_back(static_cast<std::int16_t>(u));
          vs.push_back(static_cast<std::int16_t>(v));
        }
      }
    }
  }
  const int n = static_cast<int>(us.size());
  for (std::size_t k = bins_u * bins_v; k < begin.size(); ++k) begin[k] = n;
  std::vector<std::uint8_t> descs(32 * static_cast<std::size_t>(n), 7);
  std::uint8_t query[32];
  std::fill(std::begin(query), std::end(query), 9);  // SAD 64 to every feature
  const kernels::SearchGrid grid = gridOf(descs, us, vs, begin, bins_u, bins_v, bin, width, height);
  for (int half = 0; half <= 70; ++half) {
    for (const int cu : {0, 31, 59, 100}) {
      const int cv = (cu * 7 + half) % height;
      int want = -1, inside = 0;
      for (int i = 0; i < n; ++i) {
        if (std::abs(us[i] - cu) > half || std::abs(vs[i] - cv) > half) continue;
        if (want < 0) want = i;
        ++inside;
      }
      Best got;
      kernels::searchWindow(query, grid, 0, cu - half, cu + half, cv - half, cv + half, &got.index,
                            &got.cost, &got.second);
      ASSERT_EQ(got.index, want) << half << " " << cu;
      ASSERT_EQ(got.cost, want < 0 ? std::numeric_limits<std::uint32_t>::max() : 64u);
      ASSERT_EQ(got.second, inside < 2 ? std::numeric_limits<std::uint32_t>::max() : 64u);
    }
  }
}

TEST(Kernels, SsdAroundEqualsTheSsdOfEachNeighbourDescriptor) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255);
  FilterImages f;
  f.width = 40;
  f.height = 30;
  f.du.resize(f.width * f.height);
  f.dv.resize(f.width * f.height);
  for (auto& x : f.du) x = static_cast<std::uint8_t>(byte(rng));
  for (auto& x : f.dv) x = static_cast<std::uint8_t>(byte(rng));
  std::uint8_t ref[32];
  for (auto& r : ref) r = static_cast<std::uint8_t>(byte(rng));
  const int lo = kernels::kDescriptorRadius + 1;
  for (int v = lo; v < f.height - lo; ++v) {
    for (int u = lo; u < f.width - lo; ++u) {
      std::uint32_t block[9];
      kernels::ssdAround(f.du.data(), f.dv.data(), f.width, u, v, ref, block);
      for (int k = 0; k < 9; ++k) {
        std::uint8_t d[32];
        computeDescriptor(f, u + k % 3 - 1, v + k / 3 - 1, d);
        ASSERT_EQ(block[k], kernels::ssd32(ref, d)) << u << "," << v << " " << k;
      }
    }
  }
}

}  // namespace
}  // namespace ovo::frontend
